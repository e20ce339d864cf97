"""A part plan with the probe's reach and its collision-free path, on ../shared/testdata/Ventilator.stp.

    /usr/bin/python3 benchmarks/probe_path.py [--faces 11,61,101,151,201,251] [--strategy optimal]

Prints the plan's table (points tilted or unreachable per face, faces the probe cannot reach at
all), the path's length against the straight nearest-neighbour order (with and without the
detours it needs), the detours over the clearance plane and the estimated measuring time.
Asserts nothing; without the file it says so and stops.
"""
import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import cmmsampling  # noqa: E402

VENTILATOR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "testdata",
                          "Ventilator.stp")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--faces", type=lambda t: [int(k) for k in t.split(",")], default=[11, 61, 101, 151, 201, 251])
    parser.add_argument("--strategy", default="optimal")
    parser.add_argument("--tolerance", type=float, default=0.05)
    args = parser.parse_args()
    if not os.path.isfile(VENTILATOR):
        print(f"{VENTILATOR} is not there: nothing to measure")
        return
    import Part

    shape = Part.read(VENTILATOR)
    probe = cmmsampling.Probe()
    start = time.perf_counter()
    plan = cmmsampling.plan(shape, tolerance=args.tolerance, strategy=args.strategy, faces=args.faces, probe=probe,
                            grid=30, n_max=200, time_limit=5.0)
    print(f"Ventilator.stp, faces {args.faces}, {args.strategy}, {args.tolerance} mm, probe {probe}: "
          f"{time.perf_counter() - start:.0f} s")
    print(plan.table())
    tilted = sum(face.tilted for face in plan.placed)
    unreached = sum(face.unreached for face in plan.placed)
    print(f"{plan.n_total} points on {len(plan.placed)} faces: {tilted} reached only tilted, {unreached} refused by "
          f"OCC at the final points; {len(plan.refused)} faces the probe reaches nowhere")
    start = time.perf_counter()
    moves = cmmsampling.probe_moves(plan)
    print(f"path {moves.travel:.1f} mm ({moves.detours} detours over the clearance plane); the straight "
          f"nearest-neighbour order {moves.straight:.1f} mm, with the detours it needs {moves.baseline:.1f} mm; "
          f"about {moves.seconds:.0f} s of measuring; path computed in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
