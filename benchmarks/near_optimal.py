"""How close each strategy comes to a local optimum, on the reference surface.

For N = 49, 81, 144 (default pole counts 5, 6, 8 per direction, 60 x 60 grid, check grid 180 x 180):
uniform parametric, uniform Cartesian, the paper's PSO and the near-optimal strategy, each in mm
and as a multiple of the local bound about its own substitute (the least maximum that reshaping
it along its normals could reach) on the grid and the check grid, with run times.
Run: /usr/bin/python3 benchmarks/near_optimal.py [N ...]
"""
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import cmmsampling  # noqa: E402

STRATEGIES = ("uniform_parametric", "uniform_cartesian", "pso", "optimal")


def table(face, n):
    """Print the rows for one N."""
    results = [cmmsampling.sample(face, n, strategy, occ_check=False) for strategy in STRATEGIES]
    print(f"\nN = {n}, substitute {results[0].settings['fit_poles']} poles")
    print(f"{'strategy':<20} {'max mm':>8} {'x bound':>8} {'check mm':>9} {'x bound':>8} {'time s':>7} "
          f"{'bound s':>7}")
    for result in results:
        start = time.perf_counter()
        result.bounds()
        bound_s = time.perf_counter() - start
        print(f"{result.strategy:<20} {result.deviation.maximum:>8.4f} {result.multiple_of_bound():>8.3f} "
              f"{result.check.maximum:>9.4f} {result.multiple_of_bound(check=True):>8.3f} "
              f"{result.timings['total_s']:>7.1f} {bound_s:>7.1f}")


if __name__ == "__main__":
    reference = cmmsampling.reference_face()
    for count in [int(a) for a in sys.argv[1:]] or (49, 81, 144):
        table(reference, count)
