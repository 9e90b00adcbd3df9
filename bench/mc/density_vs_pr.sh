#!/usr/bin/env bash
# Core packing density vs rebound probability p_r for the two scenes of docs/mc.md.
# Usage: bench/mc/density_vs_pr.sh BUILD_DIR OUT_DIR [VOXEL_CYL_MM] [SEEDS...]
# Prints one JSON line per run (voxpack_mc_density output + scene name + seed).
set -euo pipefail
build=${1:?build dir}
out=${2:?output dir}
vcyl=${3:-0.54}
shift 3 || true
seeds=("$@")
[ ${#seeds[@]} -eq 0 ] && seeds=(1 2 3)
mkdir -p "$out"
here=$(cd "$(dirname "$0")/../.." && pwd)
for pr in 0 0.05 0.1 0.2 0.3 0.5; do
  for seed in "${seeds[@]}"; do
    f="$out/spheres_pr${pr}_s${seed}.h5"
    "$build/bin/voxpack" -q pack --config "$here/samples/spheres_mc.toml" --seed "$seed" \
      --rebound-probability "$pr" -o "$f" >/dev/null
    echo "{\"scene\":\"spheres\",\"seed\":$seed,\"r\":$("$build/bin/voxpack_mc_density" "$f" 3)}"
    f="$out/cylinders_pr${pr}_s${seed}.h5"
    "$build/bin/voxpack" -q pack --config "$here/samples/paper_mc.toml" --seed "$seed" \
      --voxel-size "$vcyl" --rebound-probability "$pr" -o "$f" >/dev/null
    echo "{\"scene\":\"cylinders\",\"seed\":$seed,\"voxel_mm\":$vcyl,\"r\":$("$build/bin/voxpack_mc_density" "$f" 5.4)}"
  done
done
