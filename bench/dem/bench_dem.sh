#!/usr/bin/env bash
# DEM speed and density measurements (docs/dem.md). Not run by ctest: minutes to hours.
#   bench/dem/bench_dem.sh BUILD_DIR OUT_DIR [paper|paper-density|spheres|all]
# Each run writes OUT_DIR/NAME.h5 and OUT_DIR/NAME.json (wall time, simulated time, time step,
# particle-steps per second, share integrated with sleeping, densities from dem_bed_density).
set -euo pipefail
build=${1:?build dir}
out=${2:?output dir}
which=${3:-all}
vox="$build/bin/voxpack"
dens="$build/bin/dem_bed_density"
mkdir -p "$out"

run() {  # NAME D_MM ARGS...
  local name=$1 d=$2
  shift 2
  /usr/bin/time -f "%e" -o "$out/$name.time" "$vox" pack --mode dem "$@" \
    -o "$out/$name.h5" >"$out/$name.out" 2>"$out/$name.err"
  "$vox" info --json "$out/$name.h5" >"$out/$name.info.json"
  "$dens" "$out/$name.h5" "$d" "$out/$name.radial.csv" >"$out/$name.density.json"
  /usr/bin/python3 - "$out/$name" <<'PY'
import json, sys
base = sys.argv[1]
info = json.load(open(base + ".info.json"))
dens = json.load(open(base + ".density.json"))
dem = info["provenance"]["dem"]
res = {
    "status": info["provenance"]["status"],
    "particles": info["particles"],
    "wall_time_s": info["provenance"]["wall_time_s"],
    "dem_wall_time_s": dem["dem_wall_time_s"],
    "simulated_time_s": dem["simulated_time_s"],
    "time_step_s": dem["time_step_s"],
    "steps": dem["steps"],
    "particle_steps_per_s": dem["particle_steps"] / dem["dem_wall_time_s"],
    "integrated_share": dem["integrated_particle_steps"] / max(1, dem["particle_steps"]),
    "max_overlap_mm": dem["max_overlap_mm"],
    "density": dens,
}
json.dump(res, open(base + ".json", "w"), indent=1)
print(base, json.dumps(res))
PY
}

if [[ $which == spheres || $which == all ]]; then
  for mu in 0.3 0; do
    for seed in 1 2 3; do
      run "spheres_mu${mu}_s${seed}" 3 --threads 1 --shape sphere:d=3 --container cylinder:d=24,h=120 \
        --voxel-size 0.3 --count 600 --seed "$seed" --friction "$mu" --restitution 0.5
    done
  done
fi
if [[ $which == paper || $which == all ]]; then
  # Timings: 2 threads, one run at a time (docs/dem.md).
  for vox_mm in 0.54 0.27; do
    for sleep in on off; do
      run "paper_${vox_mm}_sleep_${sleep}" 5.4 --threads 2 --config samples/paper_dem.toml --seed 1 \
        --voxel-size "$vox_mm" --sleeping "$sleep"
    done
  done
  run "paper_0.54_tap10" 5.4 --threads 2 --config samples/paper_dem.toml --seed 1 --voxel-size 0.54 \
    --tap-cycles 10
fi
if [[ $which == paper-density || $which == all ]]; then
  # Densities: seeds and resolutions (1 thread each; run two at a time if you like).
  for seed in 1 2 3; do
    run "paper_0.27_s${seed}" 5.4 --threads 1 --config samples/paper_dem.toml --seed "$seed" \
      --voxel-size 0.27
  done
  run "paper_0.18_s1" 5.4 --threads 1 --config samples/paper_dem.toml --seed 1 --voxel-size 0.18
  run "paper_0.27_tap10_s1" 5.4 --threads 1 --config samples/paper_dem.toml --seed 1 \
    --voxel-size 0.27 --tap-cycles 10
fi
