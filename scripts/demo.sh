#!/usr/bin/env bash
# Main job: install what is missing, then sample the built-in reference surface with every
# strategy at N = 81 (PSO with the paper's parameters) and print the deviation table; measure the
# best strategy's points on a virtual CMM, inspect them (out/inspection/); compare the strategies over N
# (out/report/).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
exec /usr/bin/python3 -m cmmsampling demo "$@"
