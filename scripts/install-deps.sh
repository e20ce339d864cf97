#!/usr/bin/env bash
# Install what cmmsampling needs on Debian (12, 13 or sid), only what is missing: FreeCAD (Part/OCC),
# numpy, scipy, Xvfb for the GUI tests, pytest, hypothesis, matplotlib, lxml (QIF files, checked
# against the QIF 3.0 schemas), threadpoolctl, Dask's distributed (a part plan on a cluster): the
# Python packages package.xml declares (tests/package/test_package_xml.py holds them together).
# --list prints the package names instead (scripts/test-matrix.sh installs the same into its roots).
# HOST_PACKAGES go on this machine only, not into those roots: g++ builds NIST's I++ DME command
# checker and response parser for the tests (tests/support/ippdme.py), which run once, on the host.
# mypy type-checks the package (tests/package/test_types.py, the quality layer).
set -euo pipefail
PACKAGES=(freecad python3-numpy python3-scipy xvfb xauth python3-pytest python3-matplotlib python3-lxml
          python3-hypothesis python3-threadpoolctl python3-distributed)
HOST_PACKAGES=(g++ mypy)
if [ "${1:-}" = "--list" ]; then
  printf '%s\n' "${PACKAGES[@]}"
  exit 0
fi
missing=()
for p in "${PACKAGES[@]}" "${HOST_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "Installing: ${missing[*]}" >&2
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
