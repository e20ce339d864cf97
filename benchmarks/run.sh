#!/usr/bin/env bash
# The benchmarks: installs what is missing (Debian packages, and pyswarms from PyPI into a
# separate virtual environment that sees Debian's numpy, scipy and FreeCAD), then runs them and
# writes each one's page in docs/benchmarks/ (benchmarks/page.py), never edited by hand.
#   bash benchmarks/run.sh                 # all of them (about an hour on 2 cores)
#   bash benchmarks/run.sh speed memory    # those named (the names below)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
if ! dpkg-query -W -f='${Status}' python3-venv 2>/dev/null | grep -q "install ok installed"; then
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends python3-venv python3-pip >/dev/null
fi
VENV="$PWD/.venv-bench"
[ -x "$VENV/bin/python" ] || /usr/bin/python3 -m venv --system-site-packages "$VENV"
# importing pyswarms writes a report.log into the working folder: check it from a scratch one
(cd "$(mktemp -d)" && "$VENV/bin/python" -c "import pyswarms" 2>/dev/null) || "$VENV/bin/pip" install -q pyswarms
PY="$VENV/bin/python"
page() { "$PY" benchmarks/page.py "$@"; }
run_one() {
  case "$1" in
    speed) page speed "Speed of the swarm's fitness and of the paper's PSO (quiet machine)" "$PY" benchmarks/speed.py ;;
    speed-busy) page speed-busy "Speed of the swarm's fitness and of the paper's PSO beside a CPU-bound process" \
                  "$PY" benchmarks/speed.py --beside-busy ;;
    delivered-deviation) "$PY" benchmarks/delivered_deviation.py ;;
    near-optimal) page near-optimal "How close each strategy comes to a local optimum" "$PY" benchmarks/near_optimal.py ;;
    part-plan-speed) page part-plan-speed "A 20-face part plan on one and two processes and on Dask" \
                       "$PY" benchmarks/part_plan.py speed ;;
    part-plan-ventilator) page part-plan-ventilator \
                            "The whole Ventilator to 0.05 mm, uniform parametric, on 2 processes and on Dask" \
                            "$PY" benchmarks/part_plan.py ventilator --strategies uniform_parametric --dask ;;
    part-plan-ventilator-optimal) page part-plan-ventilator-optimal \
                                    "The whole Ventilator to 0.05 mm, optimal, on 2 processes" \
                                    "$PY" benchmarks/part_plan.py ventilator --strategies optimal ;;
    part-plan-points) page part-plan-points "Points a tolerance needs: optimal against uniform parametric" \
                        "$PY" benchmarks/part_plan.py points ;;
    probe-plans) page probe-plans "Probe plans against their targets, as ratios to the prototype (quiet machine)" \
                   "$PY" benchmarks/probe_plans.py ;;
    probe-plans-busy) page probe-plans-busy \
                        "Probe plans against their targets, as ratios to the prototype, beside a CPU-bound process" \
                        "$PY" benchmarks/probe_plans.py --beside-busy ;;
    probe-path) page probe-path "A part plan with the probe's reach and path (Ventilator.stp)" "$PY" benchmarks/probe_path.py ;;
    probe-orientations) page probe-orientations \
                          "Tip changes of the Ventilator's probe plans, before and after the orientations' set cover" \
                          "$PY" benchmarks/probe_orientations.py ;;
    long-runs) page long-runs "Big and long runs: time and memory" "$PY" benchmarks/long_runs.py ;;
    paper-run-spread) page paper-run-spread "The paper's run over 12 seeds: the spread a test must allow" \
                        "$PY" benchmarks/paper_run_spread.py 12 ;;
    inspection-speed) page inspection-speed "Inspecting 2,000 and 20,000 measured points (quiet machine)" \
                        "$PY" benchmarks/inspection_speed.py ;;
    inspection-speed-busy) page inspection-speed-busy \
                             "Inspecting 2,000 and 20,000 measured points beside a CPU-bound process" \
                             "$PY" benchmarks/inspection_speed.py --beside-busy ;;
    series-error) page series-error "Sampling aimed at a series' error: points a next part needs, with and without the model" \
                    "$PY" benchmarks/series_error.py ;;
    until-decided) page until-decided "Measuring until decided against a fixed plan: 100 simulated parts on two faces" \
                     "$PY" benchmarks/until_decided.py ;;
    memory) page memory "Peak memory against sample()'s estimate" "$PY" benchmarks/memory.py --quick ;;
    first-run-estimate) page first-run-estimate "The time estimate against a first run, in a fresh process" \
                          "$PY" benchmarks/first_run_estimate.py ;;
    reopen) page reopen "Reopening a document of results in the GUI: time and freeze" "$PY" benchmarks/reopen.py ;;
    *) echo "unknown benchmark '$1'; choose from: $ALL" >&2; return 2 ;;
  esac
}
ALL="inspection-speed inspection-speed-busy speed part-plan-speed part-plan-ventilator part-plan-ventilator-optimal speed-busy long-runs memory near-optimal probe-plans probe-plans-busy probe-path probe-orientations part-plan-points delivered-deviation paper-run-spread series-error until-decided first-run-estimate reopen"
status=0
for name in ${@:-$ALL}; do
  echo "== $name"
  run_one "$name" || status=$?
done
exit "$status"
