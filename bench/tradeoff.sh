#!/usr/bin/env bash
# The speed/accuracy sweep (issue 9): voxels per particle diameter x mode (MC, DEM) x seeds
# for a cylinder scene (the paper's pellets) and a sphere scene. Writes JSON, CSV, plots and
# the measured tables of docs/tradeoff.md.
#   bench/tradeoff.sh            full sweep (6, 8, 10, 15, 20, 30 voxels per d; 3 seeds)
#   bench/tradeoff.sh --quick    reduced sweep (< 10 minutes on 2 cores)
#   --modes mc,dem --scenes cylinders,spheres --vpd 6,10 --seeds 1,2 --threads N (default 1)
# Output: out/tradeoff/ (override with VOXPACK_TRADEOFF_OUT).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
if [[ ! -x "$root/build/bin/voxpack" ]]; then bash "$root/scripts/build.sh"; fi
exec /usr/bin/python3 "$root/bench/tradeoff/tradeoff.py" --voxpack "$root/build/bin/voxpack" \
  --out "${VOXPACK_TRADEOFF_OUT:-$root/out/tradeoff}" "$@"
