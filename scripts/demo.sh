#!/usr/bin/env bash
# The main job on the bundled recordings, no hardware needed: identify M1 and
# M2, train the M3 residual network, export the model header, replay the
# recordings natively through the board observer, print the RMSE table and
# write an HTML report; then diagnose which physical effects are missing, add
# them and show the error fall. Output goes to out/ (or the folder given).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
bash scripts/bootstrap.sh
exec .venv/bin/hpddo demo --out "${1:-out}"
