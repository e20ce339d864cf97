"""How far the paper's PSO result moves with the swarm's random path, on the reference surface.

The paper's run (81 points, 25 particles x 3000 iterations) for seeds 0..K-1 on one process,
with the uniform parametric layout it starts from beside it, in mm (the delivered substitute's
two-sided maximum, and OpenCASCADE's distance both ways at the worst nodes beside it). Another processor's rounding sends the swarm along another path, as another
seed does (its fitness is single precision, so the last digits decide which particle leads), so
the spread over seeds is the spread a test of the seed-0 figure must allow on any processor:
tests/package/test_api.py holds the figure to the band this page prints.
Run: /usr/bin/python3 benchmarks/paper_run_spread.py [K]   (default 10 seeds)
"""
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import cmmsampling  # noqa: E402


def run(seeds):
    """Print one row a seed, then the spread: the median and each end's distance from it."""
    face = cmmsampling.reference_face()
    found = cmmsampling.sample(face, 81, "uniform_parametric").deviation
    uniform = found.maximum
    print(f"uniform parametric, N = 81: {uniform:.4f} mm (OCC {found.occ_maximum:.4f} mm)")
    print(f"{'seed':>4} {'PSO max mm':>10} {'OCC mm':>8} {'x uniform':>9} {'time s':>7}")
    figures = []
    for seed in range(seeds):
        start = time.perf_counter()
        found = cmmsampling.sample(face, 81, "pso", seed=seed, workers=1).deviation
        figures.append(found.maximum)
        print(f"{seed:>4} {found.maximum:>10.4f} {found.occ_maximum:>8.4f} {found.maximum / uniform:>9.3f} "
              f"{time.perf_counter() - start:>7.1f}")
    figures = np.array(figures)
    median = float(np.median(figures))
    print(f"median {median:.4f} mm, lowest {figures.min():.4f} ({figures.min() / median - 1:+.1%}), "
          f"highest {figures.max():.4f} ({figures.max() / median - 1:+.1%}); "
          f"all below uniform: {bool(np.all(figures < uniform))}")


if __name__ == "__main__":
    run(int(sys.argv[1]) if len(sys.argv) > 1 else 10)
