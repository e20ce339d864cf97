#!/usr/bin/env bash
# Install what is missing, then run the test suite with Debian's Python and the real FreeCAD: the
# headless tests (pytest) and, side by side with them, the GUI tests inside FreeCAD under a virtual
# X server (their output follows the headless run's); with --quality the quality layer's headless
# tests run in a third process beside them (pytest alone keeps one core busy: on two cores the
# layers side by side end sooner than one after the other).
#   bash scripts/test.sh                 # every test but those marked quality or slow (pytest.ini)
#   bash scripts/test.sh --quality       # the quality layer too: what CI runs on the host
#   bash scripts/test.sh --versions      # what a FreeCAD version can change: all but the tests marked
#                                        # once too (what the FreeCAD 1.0 and 1.1 roots run)
#   bash scripts/test.sh --quick         # the quick layer alone, headless (seconds): while editing
#   bash scripts/test.sh -k export       # other arguments go to the headless pytest run
# Exit code: non-zero if either run fails.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
layers=(-m "not slow and not quality")   # what the GUI run selects
headless=("${layers[@]}")                # what the headless run selects (with --quality, that layer runs apart)
with_quality=0
if [ "${1:-}" = "--quality" ]; then
  layers=(-m "not slow")
  with_quality=1
  shift
elif [ "${1:-}" = "--versions" ]; then
  layers=(-m "not slow and not quality and not once")
  headless=("${layers[@]}")
  shift
elif [ "${1:-}" = "--quick" ]; then
  shift
  exec /usr/bin/python3 -m pytest -q -p no:cacheprovider tests -m quick "$@"
fi
gui_log="$(mktemp)"
quality_log="$(mktemp)"
trap 'rm -f "$gui_log" "$quality_log"' EXIT
start=$SECONDS
bash scripts/run-gui-tests.sh "${layers[@]}" >"$gui_log" 2>&1 &
gui=$!
quality=""
if [ "$with_quality" = 1 ]; then
  /usr/bin/python3 -m pytest -q -p no:cacheprovider tests -m "quality and not slow" "$@" >"$quality_log" 2>&1 &
  quality=$!
fi
status=0
/usr/bin/python3 -m pytest -q -p no:cacheprovider tests "${headless[@]}" "$@" || status=$?
echo "[test] headless: $((SECONDS - start)) s, exit $status" >&2
if [ -n "$quality" ]; then
  quality_status=0
  wait "$quality" || quality_status=$?
  [ "$quality_status" -ne 5 ] || quality_status=0   # 5: arguments that select none of its tests
  cat "$quality_log"
  echo "[test] headless quality layer: exit $quality_status; done at $((SECONDS - start)) s" >&2
  [ "$quality_status" -eq 0 ] || status=$quality_status
fi
gui_status=0
wait "$gui" || gui_status=$?
cat "$gui_log"
echo "[test] GUI: exit $gui_status; all done in $((SECONDS - start)) s" >&2
[ "$gui_status" -eq 0 ] || status=$gui_status
exit "$status"
