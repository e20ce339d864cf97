"""How long the inspection of many measured points takes, and against what.

Points on the reference surface with a 5 um form error, misplaced (0.3, -0.2, 0.8 deg; 1, 0.5,
0.2 mm), labelled and paired with their nominals, are inspected by min-max (ISO 1101's minimum
zone, the default) and by best fit. The yardstick, measured in the same run: one pass of OCC's
per-point closest distance over the same points, which every step of the alignment used to make
(an alignment takes 2 to 6 steps). Optionally beside a CPU-bound process (--beside-busy).
Run: /usr/bin/python3 benchmarks/inspection_speed.py [N ...] [--beside-busy]
"""
import multiprocessing
import os
import sys
import time

import numpy as np
from scipy.spatial.transform import Rotation

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import cmmsampling  # noqa: E402
from cmmsampling.inspection.judge import Planned  # noqa: E402
from cmmsampling.measurement import closest_points  # noqa: E402


def measured_points(face, count, seed=1):
    """(nominal (N, 3), measured (N, 3), normals (N, 3)) on the face, mm."""
    rng = np.random.default_rng(seed)
    u0, u1, v0, v1 = face.ParameterRange
    uv = np.column_stack([rng.uniform(u0, u1, count), rng.uniform(v0, v1, count)])
    nominal = np.array([tuple(face.valueAt(*p)) for p in uv])
    normals = np.array([tuple(face.normalAt(*p)) for p in uv])
    touched = nominal + 0.005 * np.sin(nominal[:, :1] / 7.0) * normals
    centre = touched.mean(axis=0)
    measured = Rotation.from_rotvec(np.radians([0.3, -0.2, 0.8])).apply(touched - centre) + centre + [1.0, 0.5, 0.2]
    return nominal, measured, normals


def run(counts):
    """Print one row a point count."""
    face = cmmsampling.reference_face()
    print(f"{'points':>7} {'OCC pass s':>10} {'min-max s':>9} {'steps':>5} {'best fit s':>10} {'steps':>5} "
          f"{'min-max / OCC pass':>18} {'profile mm':>10}")
    for count in counts:
        nominal, measured, normals = measured_points(face, count)
        labels = [f"P{k + 1}" for k in range(count)]
        planned = Planned(labels, nominal, [face], ["face"], np.zeros(count, dtype=int))
        given = cmmsampling.PointSet(labels, measured, normals)
        start = time.perf_counter()
        closest_points(face, measured)
        occ = time.perf_counter() - start
        row = []
        for alignment in ("min_max", "best_fit"):
            start = time.perf_counter()
            found = cmmsampling.inspect(planned, given, alignment=alignment)
            row.append((time.perf_counter() - start, found.alignment.iterations, found.profile))
        (zone_s, zone_steps, profile), (fit_s, fit_steps, _) = row
        print(f"{count:>7} {occ:>10.1f} {zone_s:>9.1f} {zone_steps:>5} {fit_s:>10.1f} {fit_steps:>5} "
              f"{zone_s / occ:>18.2f} {profile:>10.5f}")


def busy(stop):
    """Spin until ``stop`` (an Event) is set: a CPU-bound neighbour."""
    while not stop.is_set():
        sum(i * i for i in range(10000))


if __name__ == "__main__":
    arguments = [a for a in sys.argv[1:] if a != "--beside-busy"]
    counts = [int(a) for a in arguments] or [2000, 20000]
    stop, neighbour = multiprocessing.Event(), None
    if "--beside-busy" in sys.argv:
        neighbour = multiprocessing.Process(target=busy, args=(stop,), daemon=True)
        neighbour.start()
        print("beside a CPU-bound process")
    try:
        run(counts)
    finally:
        stop.set()
        if neighbour is not None:
            neighbour.join(5)
    print(f"{os.cpu_count()} cores")
