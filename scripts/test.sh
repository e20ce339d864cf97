#!/usr/bin/env bash
# Install what is missing, then run the whole test suite with Debian's Python and the real FreeCAD.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
exec /usr/bin/python3 -m pytest -q -p no:cacheprovider tests "$@"
