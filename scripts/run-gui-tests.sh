#!/usr/bin/env bash
# Run the GUI tests (tests/gui) inside the real FreeCAD GUI under a virtual X server.
# The addon is installed into a temporary HOME (a symlink to this checkout) in the Mod folder
# FreeCAD names for a new user (~/.local/share/FreeCAD/Mod; FreeCAD 1.1: .../FreeCAD/v1-1/Mod),
# so the user's own FreeCAD configuration is never touched, and FreeCAD starts in that HOME, as a
# user's does, never in the checkout. Extra arguments go to pytest, e.g.
# -k cancel. Screenshots: artifacts/gui/. Exit code: pytest's.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
home="$(mktemp -d)"
trap 'rm -rf "$home"' EXIT
export HOME="$home" XDG_DATA_HOME="$home/.local/share" XDG_CONFIG_HOME="$home/.config"
mods="$(freecadcmd -c 'import FreeCAD; print(FreeCAD.getUserAppDataDir())' | tail -n 1)Mod"
mkdir -p "$mods"
ln -s "$root" "$mods/cmmsampling"
export QTWEBENGINE_DISABLE_SANDBOX=1
pytest_args=""
if [ "$#" -gt 0 ]; then pytest_args="$(printf "%q " "$@")"; fi
export CMMSAMPLING_ROOT="$root" CMMSAMPLING_PYTEST_ARGS="$pytest_args"
export CMMSAMPLING_ARTIFACTS="${CMMSAMPLING_ARTIFACTS:-$root/artifacts/gui}"
cd "$home"
set +e
timeout --kill-after=10 "${CMMSAMPLING_GUI_TIMEOUT:-3600}" \
  xvfb-run -a -s "-screen 0 1280x1024x24" freecad "$root/tests/gui/run_gui_tests.py" 2>"$home/freecad.stderr"
code=$?
set -e
if [ "$code" -ne 0 ]; then
  echo "FreeCAD exited with $code; its error output:" >&2
  grep -v -e "QtWebEngine" -e "command_buffer_proxy" "$home/freecad.stderr" | tail -n 40 >&2 || true
fi
exit "$code"
