#!/usr/bin/env bash
# Speed benchmark: installs what is missing (Debian packages, and pyswarms from PyPI into a
# separate virtual environment that sees Debian's numpy, scipy and FreeCAD), then runs it.
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
exec "$VENV/bin/python" benchmarks/speed.py "$@"
