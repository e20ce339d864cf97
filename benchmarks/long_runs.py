"""Big and long runs: N = 1000 on a 200 x 200 grid, and ten PSO runs in a row in one process.

Prints the wall time and peak resident memory of the big runs, and the resident memory after each
of the ten runs (growth would show a leak). Run: /usr/bin/python3 benchmarks/long_runs.py
"""
import os
import resource
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import cmmsampling  # noqa: E402


def resident_mib():
    """Current resident set of this process, MiB."""
    with open("/proc/self/status") as status:
        return int(next(line for line in status if line.startswith("VmRSS")).split()[1]) / 1024


def peak_mib():
    """Peak resident set of this process so far, MiB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def big_runs(face):
    """N = 1000 points, 200 x 200 grid: blind, PSO and optimal strategies."""
    print("N = 1000, grid 200 x 200 (check grid 600 x 600), reference surface")
    print(f"{'strategy':<20} {'wall s':>8} {'max mm':>10} {'peak MiB':>9}")
    runs = (("uniform_parametric", {}), ("halton", {}), ("pso", {"iterations": 50}),
            ("optimal", {"max_evaluations": 100}))
    for strategy, options in runs:
        start = time.perf_counter()
        result = cmmsampling.sample(face, 1000, strategy, grid=200, **options)
        print(f"{strategy:<20} {time.perf_counter() - start:>8.1f} {result.deviation.maximum:>10.5f} "
              f"{peak_mib():>9.0f}")
        del result


def repeated_runs(face, count=10):
    """Ten PSO runs in a row (N = 81, 300 iterations): resident memory after each."""
    print(f"\n{count} PSO runs in a row (N = 81, 300 iterations): resident MiB after each")
    sizes = []
    for _ in range(count):
        cmmsampling.sample(face, 81, "pso", iterations=300)
        sizes.append(resident_mib())
    print(" ".join(f"{s:.0f}" for s in sizes))
    print(f"growth from run 2 to run {count}: {sizes[-1] - sizes[1]:+.1f} MiB")


if __name__ == "__main__":
    reference = cmmsampling.reference_face()
    big_runs(reference)
    repeated_runs(reference)
