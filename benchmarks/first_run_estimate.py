"""How well the time estimate holds on a first run: the Sample face panel shows
``cmmsampling.time_needed`` ("Time: about 14 s") before the user's first run, in a FreeCAD that has
run nothing yet. Each case runs in a fresh Python process: the estimate, then the run it
estimates (the first in that process: imports, caches and the face's set-up all still to do),
then the same run again. Printed: the estimate, both runs and their ratios to the estimate; the
last lines give the range of the first runs' ratios, the factor the panel's estimate holds within.
Run: /usr/bin/python3 benchmarks/first_run_estimate.py
"""
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TESTDATA = os.path.join(os.path.dirname(ROOT), "shared", "testdata")
# (what, face: Python text giving `face`, N, strategy, options): the panel's defaults (PSO, 81
# points) on the reference face, on a Ventilator blade and on a 2 mm strip, and a blind run.
CASES = [
    ("reference face, PSO", "cmmsampling.reference_face().Faces[0]", 81, "pso", {}),
    ("reference face, Halton", "cmmsampling.reference_face().Faces[0]", 81, "halton", {}),
    ("Ventilator Face176, PSO", f"Part.read({os.path.join(TESTDATA, 'Ventilator.stp')!r}).Faces[175]", 81, "pso", {}),
    ("2 mm strip, PSO", "Part.makePlane(100, 2).Faces[0]", 25, "pso", {}),
]
CHILD = """
import json, sys, time
sys.path.insert(0, sys.argv[1])
sys.path.append('/usr/lib/freecad-python3/lib')
started = time.perf_counter()
import FreeCAD, Part
import cmmsampling
face = eval(sys.argv[2])
n, strategy, options = int(sys.argv[3]), sys.argv[4], json.loads(sys.argv[5])
ready = time.perf_counter() - started
start = time.perf_counter()
estimate = cmmsampling.time_needed(face, n, strategy, **options)
estimating = time.perf_counter() - start
runs = []
for _ in range(2):
    start = time.perf_counter()
    cmmsampling.sample(face, n, strategy, **options)
    runs.append(time.perf_counter() - start)
print(json.dumps({"import_s": ready, "estimate": estimate, "estimating_s": estimating, "runs": runs}))
"""


def measure(face, n, strategy, options):
    """The child's figures for one case (a fresh process)."""
    done = subprocess.run([sys.executable, "-c", CHILD, ROOT, face, str(n), strategy, json.dumps(options)],
                          capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main():
    print(f"{'case':<26} {'estimate s':>10} {'first s':>8} {'ratio':>6} {'second s':>9} {'ratio':>6}")
    ratios = []
    for what, face, n, strategy, options in CASES:
        if "Ventilator" in what and not os.path.isfile(os.path.join(TESTDATA, "Ventilator.stp")):
            continue
        figures = measure(face, n, strategy, options)
        first, second = figures["runs"]
        estimate = figures["estimate"]
        ratios.append(first / estimate)
        print(f"{what:<26} {estimate:>10.2f} {first:>8.2f} {first / estimate:>6.2f} {second:>9.2f} "
              f"{second / estimate:>6.2f}")
    print(f"first runs took {min(ratios):.2f} to {max(ratios):.2f} times the estimate shown before them")


if __name__ == "__main__":
    main()
