#!/usr/bin/env bash
# Install what is missing, then run the test suite with Debian's Python and the real FreeCAD: the
# headless tests (pytest) and, side by side with them, the GUI tests inside FreeCAD under a virtual
# X server (their output follows the headless run's). Both spend much of their time waiting (worker
# processes, the GUI's timers), so on two cores together they take about as long as the longer one.
#   bash scripts/test.sh                 # every test but those marked quality or slow (pytest.ini)
#   bash scripts/test.sh --quality       # the quality layer too: what CI runs on the host
#   bash scripts/test.sh --quick         # the quick layer alone, headless (seconds): while editing
#   bash scripts/test.sh -k export       # other arguments go to the headless pytest run
# Exit code: non-zero if either run fails.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
layers=(-m "not slow and not quality")
if [ "${1:-}" = "--quality" ]; then
  layers=(-m "not slow")
  shift
elif [ "${1:-}" = "--quick" ]; then
  shift
  exec /usr/bin/python3 -m pytest -q -p no:cacheprovider tests -m quick "$@"
fi
gui_log="$(mktemp)"
trap 'rm -f "$gui_log"' EXIT
start=$SECONDS
bash scripts/run-gui-tests.sh "${layers[@]}" >"$gui_log" 2>&1 &
gui=$!
status=0
/usr/bin/python3 -m pytest -q -p no:cacheprovider tests "${layers[@]}" "$@" || status=$?
echo "[test] headless: $((SECONDS - start)) s, exit $status" >&2
gui_status=0
wait "$gui" || gui_status=$?
cat "$gui_log"
echo "[test] GUI: exit $gui_status; both done in $((SECONDS - start)) s" >&2
[ "$gui_status" -eq 0 ] || status=$gui_status
exit "$status"
