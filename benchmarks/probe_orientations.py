"""Tip changes of the Ventilator's probe plans, before and after the orientations' set cover.

    /usr/bin/python3 benchmarks/probe_orientations.py [--plans four,twenty] [--processes 2]

Plans ../shared/testdata/Ventilator.stp with the 2 mm probe to 0.05 mm, optimal (as
benchmarks/probe_plans.py: the four faces 14, 57, 60, 61, and twenty faces spread over the part),
then measures on the same points, in the same run:

* before: each point on the head orientation nearest its normal that reaches it
  (cmmsampling.access.reach.reach, as the plans took before the cover) and the path ordered by
  travel alone (``moves_through(..., by_orientation=False)``);
* per face: each face's own set cover (cmmsampling.access.reach.fewest_orientations, run on
  each face's points as the plan's faces end), the path orientation by orientation;
* after: the plan's own orientations (those covers shared across the faces where that needs
  fewer: cmmsampling.planning.plan_points.share_orientations) and its path.

Prints for each the orientations, the tip changes (changes of orientation along the path: the
index moves, a DMIS program's SNSLCT after its first), the travel and the estimated CMM time with
Motion()'s 3 s per index move (and without them); for after, the SNSLCT of the DMIS program the
plan exports as a check. Points the probe cannot reach (none on the four faces) are left out of
both paths. Asserts nothing; without the file it says so and stops.
"""
import argparse
import os
import re
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
import numpy as np  # noqa: E402

import cmmsampling  # noqa: E402
from cmmsampling.access.obstacles import Obstacles  # noqa: E402
from cmmsampling.access.probe import Motion  # noqa: E402
from cmmsampling.access.probe_moves import moves_through  # noqa: E402
from cmmsampling.access.reach import reach  # noqa: E402
from cmmsampling.planning import part_plan  # noqa: E402

VENTILATOR = os.path.join(HERE, "..", "..", "shared", "testdata", "Ventilator.stp")
PLANS = {"four": [14, 57, 60, 61], "twenty": list(range(4, 305, 15))[:20]}
TOLERANCE = 0.05


def reached_points(plan):
    """(points, normals, axes), each (N, 3), of the plan's points its probe reaches (mm, unit)."""
    kept = [(face, face.access.reachable) for face in plan.placed]
    return tuple(np.concatenate([getattr(face, name)[reachable] for face, reachable in kept])
                 for name in ("points", "normals", "axes"))


def figures_line(what, moves, points):
    """'before: 17 orientations, 19 tip changes, 2813.6 mm of travel, 139 s (82 s without index moves)'."""
    untimed = Motion(index_time=0.0).seconds(moves.travel, points, cmmsampling.Probe().approach)
    return (f"  {what}: {moves.orientations} orientations, {moves.tip_changes} tip changes, {moves.travel:.1f} mm "
            f"of travel, {moves.detours} detours; about {moves.seconds:.0f} s on the CMM ({untimed:.0f} s without "
            f"the index moves)")


def dmis_selections(plan):
    """(SNSLCT statements, distinct sensors) of the DMIS program the plan exports (None, None where
    its probe cannot reach every point: no probe path is written then)."""
    if any(face.unreached for face in plan.placed):
        return None, None
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "plan.dmi")
        cmmsampling.export(plan, path, order="probe_path")
        with open(path) as program:
            selected = re.findall(r"^SNSLCT/S\(([^)]*)\)", program.read(), re.M)
    return len(selected), len(set(selected))


def planned_with_own_covers(shape, faces, probe, processes):
    """(the plan, the axes (N, 3) of its reached points as each face's own cover left them, before
    the plan shared them)."""
    sharing = part_plan.share_orientations
    own = {}

    def recorded(plan):
        own["axes"] = reached_points(plan)[2]
        sharing(plan)

    part_plan.share_orientations = recorded
    try:
        plan = cmmsampling.plan(shape, tolerance=TOLERANCE, faces=faces, probe=probe, processes=processes)
    finally:
        part_plan.share_orientations = sharing
    return plan, own["axes"]


def measure(shape, name, faces, processes):
    """Plan ``faces`` and print the before, per-face and after figures."""
    probe = cmmsampling.Probe()
    started = time.perf_counter()
    plan, own_axes = planned_with_own_covers(shape, faces, probe, processes)
    planned = time.perf_counter() - started
    points, normals, axes = reached_points(plan)
    obstacles = Obstacles(plan.part)
    nearest = reach(probe, obstacles, points, normals)
    print(f"\n{name} faces {faces}: {len(points)} points the probe reaches ({plan.n_total} planned) on "
          f"{len(plan.placed)} faces, planned in {planned:.0f} s")
    if not nearest.reachable.all():
        print(f"  ({int((~nearest.reachable).sum())} points the fast test alone does not reach: OCC judged them)")
    started = time.perf_counter()
    before = moves_through(probe, obstacles, points, normals, np.where(nearest.reachable[:, None], nearest.axes, axes),
                           by_orientation=False)
    middle = time.perf_counter()
    per_face = moves_through(probe, obstacles, points, normals, own_axes)
    after = moves_through(probe, obstacles, points, normals, axes)
    ended = time.perf_counter()
    print(figures_line("before (nearest the normal, by travel)", before, len(points)) + f"; path {middle - started:.1f} s")
    print(figures_line("per face (each face's set cover, by orientation)", per_face, len(points)))
    print(figures_line("after (the covers shared across the faces, by orientation)", after, len(points))
          + f"; both paths {ended - middle:.1f} s")
    statements, sensors = dmis_selections(plan)
    if statements is not None:
        print(f"  the plan's DMIS program: {statements} SNSLCT, {sensors} sensors ({statements - 1} tip changes)")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--plans", type=lambda text: text.split(","), default=list(PLANS))
    parser.add_argument("--processes", type=int, default=2)
    args = parser.parse_args()
    if not os.path.isfile(VENTILATOR):
        print(f"{VENTILATOR} is not there: nothing to measure")
        return
    import Part

    shape = Part.read(VENTILATOR)
    print(f"Ventilator.stp, 2 mm probe, {TOLERANCE} mm, optimal, {args.processes} processes; "
          f"{Motion().index_time:g} s per index move")
    for name in args.plans:
        measure(shape, name, PLANS[name], args.processes)


if __name__ == "__main__":
    main()
