"""Equal-parameter against geometric maxima on a rational face, per strategy.

The rational saddle of the tests (tests/geometry.py: bicubic, 7 x 7 poles over 100 x 100 mm,
weights 0.4..2.5), N = 81, default fit and grid. For each strategy: the old measure
max |S(h) - F(h)| at equal parameters over the grid, the deviation the project reports (the
closest-point distance in space from the face's nodes to the substitute, grid and check grid),
OpenCASCADE's closest-point distance at the 50 worst nodes, and the multiple of the local bound.
Run: /usr/bin/python3 benchmarks/geometric_vs_parametric.py [N]
"""
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.join(ROOT, "tests"))

import numpy as np  # noqa: E402

import cmmsampling  # noqa: E402
from geometry import rational_saddle  # noqa: E402

STRATEGIES = ("uniform_parametric", "uniform_cartesian", "halton", "pso", "optimal")


def equal_parameter_maximum(result):
    """max |S(h) - F(h)| over the evaluation grid, mm (the measure the project used before)."""
    uv = result.problem.grid.uv.reshape(-1, 2)
    return float(np.linalg.norm(result.space.evaluate(result.poles, uv) - result.model.points(uv), axis=1).max())


def main(n):
    face = rational_saddle()
    print(f"Rational saddle, N = {n}: maxima in mm")
    print(f"{'strategy':<20} {'equal-param':>11} {'in space':>9} {'check':>8} {'OCC':>8} {'x bound':>8} {'time s':>7}")
    for strategy in STRATEGIES:
        start = time.perf_counter()
        result = cmmsampling.sample(face, n, strategy)
        elapsed = time.perf_counter() - start
        d = result.deviation
        print(f"{strategy:<20} {equal_parameter_maximum(result):>11.4f} {d.maximum:>9.4f} "
              f"{result.check.maximum:>8.4f} {d.occ_maximum:>8.4f} {result.multiple_of_bound():>8.3f} "
              f"{elapsed:>7.1f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 81)
