#!/usr/bin/env bash
# Install what is missing, then run the whole test suite with Debian's Python and the real FreeCAD:
# first the headless tests, then the GUI tests inside FreeCAD under a virtual X server.
# Arguments go to the headless pytest run (e.g. -k export). Exit code: non-zero if either fails.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
status=0
/usr/bin/python3 -m pytest -q -p no:cacheprovider tests "$@" || status=$?
bash scripts/run-gui-tests.sh || status=$?
exit "$status"
