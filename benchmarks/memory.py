"""Peak memory of sampling runs against the estimate that sample() checks before it starts.

Each run goes in a fresh process: the reference face, then one cmmsampling.sample(); measured is
the peak resident set of that process above its size before the call (the PSO swarm runs in one
process, so that the whole of it is measured). Usage:
    /usr/bin/python3 benchmarks/memory.py            (N up to 10000 for the blind and optimal runs)
    /usr/bin/python3 benchmarks/memory.py --quick    (N up to 2000)
"""
import argparse
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

RUN = """
import json, resource, sys, time
sys.path.insert(0, {root!r})
import cmmsampling
face = cmmsampling.reference_face()
strategy, n, options = {strategy!r}, {n}, {options!r}
cmmsampling.sample(face, 16, "uniform_parametric", occ_check=False)
before = int(next(l for l in open("/proc/self/status") if l.startswith("VmRSS")).split()[1])
start = time.perf_counter()
cmmsampling.sample(face, n, strategy, occ_check=False, **options)
seconds = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({{"extra_kib": peak - before, "seconds": seconds,
                  "estimate": cmmsampling.memory_needed(n, strategy, **options)}}))
"""

PLAN = [
    ("halton", (400, 2000, 4000, 10000), {}),
    ("optimal", (400, 2000, 4000, 10000), {"max_evaluations": 2}),
    ("pso", (400, 1000, 2000, 4000), {"iterations": 1, "workers": 1}),
]


def measure(strategy, n, options):
    """One run in a fresh process: the figures it prints, as a dict."""
    code = RUN.format(root=ROOT, strategy=strategy, n=n, options=options)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="N up to 2000 only")
    parser.add_argument("--strategy", help="only this strategy's runs")
    args = parser.parse_args()
    print(f"{'strategy':<10} {'N':>6} {'estimate MiB':>13} {'measured MiB':>13} {'s':>7}")
    for strategy, counts, options in PLAN:
        if args.strategy and strategy != args.strategy:
            continue
        for n in counts:
            if args.quick and n > 2000:
                continue
            got = measure(strategy, n, options)
            print(f"{strategy:<10} {n:>6} {got['estimate'] / 2**20:>13.0f} {got['extra_kib'] / 1024:>13.0f} "
                  f"{got['seconds']:>7.1f}", flush=True)


if __name__ == "__main__":
    main()
