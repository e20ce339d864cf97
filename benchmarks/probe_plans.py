"""Probe plans against their targets, each as a ratio to the prototype measured in the same run.

    /usr/bin/python3 benchmarks/probe_plans.py [--beside-busy]

The yardstick is ../shared/reference/prototype/refimpl.py: 300 of its PSO iterations on the
reference face, one BLAS thread, timed here as its docstring says (the paper's 3000 iterations are
ten times that). Then, on ../shared/testdata/Ventilator.stp with the 2 mm probe, 2 processes:

* the four faces 14, 57, 60, 61 to 0.05 mm, optimal (target: at most 20 x the prototype's 300
  iterations), with each face's outcome: met, or the reason;
* twenty faces spread over the part (every 15th from Face4) to 0.05 mm, optimal (target: at most
  3 min), with the peak memory of the processes;
* the paper's run on the reference face (N = 81, 25 particles, 3000 iterations; target: at most
  0.1 x the prototype's 3000 iterations), median of three.

With --beside-busy it all runs beside a CPU-bound process. Prints; asserts nothing. Without the
prototype or the Ventilator it says so and measures what it can.
"""
import argparse
import os
import resource
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, HERE)
import cmmsampling  # noqa: E402
from speed import busy_neighbour  # noqa: E402

SHARED = os.path.join(HERE, "..", "..", "shared")
PROTOTYPE = os.path.join(SHARED, "reference", "prototype")
VENTILATOR = os.path.join(SHARED, "testdata", "Ventilator.stp")
FOUR_FACES = [14, 57, 60, 61]
# Twenty faces spread over the part (every 15th): blades, hub and rims alike.
TWENTY_FACES = list(range(4, 305, 15))[:20]
TOLERANCE = 0.05
# The prototype's own timing command (its docstring), without the factor of ten.
PROTOTYPE_300 = ("import time, numpy as np, refimpl as r\n"
                 "cad = r.reference_surface(); fit = r.BatchFitter(cad, fctrl=6); u, v = r.uniform_param(81)\n"
                 "t = time.perf_counter(); r.pso_batch(fit, 81, iters=300, init=[np.r_[u, v]])\n"
                 "print(time.perf_counter() - t)")


def prototype_seconds():
    """Seconds of the prototype's 300 PSO iterations (median of three runs), None without it."""
    if not os.path.isfile(os.path.join(PROTOTYPE, "refimpl.py")):
        return None
    environment = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    runs = sorted(float(subprocess.run(["/usr/bin/python3", "-c", PROTOTYPE_300], cwd=PROTOTYPE, env=environment,
                                       capture_output=True, text=True, check=True).stdout.split()[-1])
                  for _ in range(3))
    return runs[1]


def ratio_line(what, seconds, yardstick, target, unit):
    """'<what>: 25.3 s = 11.6 x <unit> (target <= 20 x)'."""
    if yardstick is None:
        return f"{what}: {seconds:.1f} s (no prototype to compare with)"
    ratio = seconds / yardstick
    verdict = "met" if ratio <= target else "NOT met"
    return f"{what}: {seconds:.1f} s = {ratio:.3g} x {unit} (target <= {target:g} x: {verdict})"


def children_peak_mib():
    """The largest resident set any finished child process of this one reached, MiB."""
    return resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024


def probe_plan(shape, faces):
    """(seconds, PartPlan) of a plan of ``faces`` to TOLERANCE with the 2 mm probe on 2 processes."""
    start = time.perf_counter()
    made = cmmsampling.plan(shape, tolerance=TOLERANCE, faces=faces, probe=cmmsampling.Probe(), processes=2)
    return time.perf_counter() - start, made


def plans(yardstick):
    """The four-face and the twenty-face probe plans of the Ventilator."""
    if not os.path.isfile(VENTILATOR):
        print(f"{VENTILATOR} is not there: no probe plan measured")
        return
    import Part

    shape = Part.read(VENTILATOR)
    seconds, made = probe_plan(shape, FOUR_FACES)
    print(ratio_line(f"Four faces {FOUR_FACES}, 0.05 mm, optimal, 2 mm probe, 2 processes", seconds, yardstick,
                     20, "the prototype's 300 iterations"))
    print(made.table())
    slowest(made)
    reached = [face for face in made.placed if face.unreached_area < face.area]
    print(f"tolerance met on {sum(bool(face.met) for face in reached)} of the {len(reached)} faces the probe reaches")
    seconds, made = probe_plan(shape, TWENTY_FACES)
    verdict = "met" if seconds <= 180 else "NOT met"
    met = sum(bool(face.met) for face in made.placed)
    print(f"\nTwenty faces {TWENTY_FACES}, 0.05 mm, optimal, 2 mm probe, 2 processes: {seconds:.1f} s "
          f"(target <= 180 s: {verdict}); {made.n_total} points, tolerance met on {met} of "
          f"{len(made.placed)} faces with points, {len(made.refused)} hold none; peak memory of a process "
          f"{children_peak_mib():.0f} MiB")
    if yardstick is not None:
        print(f"  = {seconds / yardstick:.3g} x the prototype's 300 iterations")
    print(made.table())
    slowest(made)


def slowest(made, count=5):
    """The ``count`` slowest faces of a plan with the N their search tried, a line."""
    faces = sorted(made.faces, key=lambda face: -face.seconds)[:count]
    print("slowest faces: " + "; ".join(
        f"{face.name} {face.seconds:.1f} s (N tried {', '.join(str(t.n) for t in face.tried)})" for face in faces))


def paper_run(yardstick):
    """The paper's run on the reference face, median of three, against the prototype's 3000 iterations."""
    face = cmmsampling.reference_face()
    cmmsampling.sample(face, 25, "pso", iterations=2, occ_check=False)   # the worker process starts once
    runs = []
    for _ in range(3):
        start = time.perf_counter()
        cmmsampling.sample(face, 81, "pso", occ_check=False)
        runs.append(time.perf_counter() - start)
    median = sorted(runs)[1]
    print(ratio_line("\nThe paper's run (N = 81, 25 particles, 3000 iterations, default processes), median of 3",
                     median, None if yardstick is None else 10 * yardstick, 0.1,
                     "the prototype's 3000 iterations"))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--beside-busy", action="store_true", help="run beside a CPU-bound process")
    args = parser.parse_args()
    with busy_neighbour(args.beside_busy):
        yardstick = prototype_seconds()
        print("one CPU-bound process running beside" if args.beside_busy else "quiet machine")
        if yardstick is None:
            print(f"the prototype is not in {PROTOTYPE}: the figures are seconds only")
        else:
            print(f"The prototype's 300 PSO iterations (one BLAS thread, median of 3): {yardstick:.2f} s; its 3000: "
                  f"{10 * yardstick:.1f} s")
        plans(yardstick)
        paper_run(yardstick)


if __name__ == "__main__":
    main()
