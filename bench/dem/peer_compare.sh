#!/usr/bin/env bash
# voxpack DEM against LIGGGHTS 3.8 in the same run, one thread / one process each
# (docs/dem.md "Speed against LIGGGHTS"). Prints the ratios; raw JSON to OUT/dem_peers.json.
#   bench/dem/peer_compare.sh BUILD_DIR OUT_DIR [spheres|cylinders|all] [SEED] [CONTACT_VOXELS]
# CONTACT_VOXELS (default "0"): the cylinder scene is run by voxpack once per value of
# --contact-voxel (mm; 0 = the lattice's 0.27 mm), each against the same LIGGGHTS run; the bed
# is digitised at 0.27 mm every time (docs/dem.md "Contact nodes coarser than the lattice").
# Scenes (bench/peers/README.md):
#   spheres:   2000 spheres d 5.4 mm, column D/d 8 (43.2 mm), mu 0.3, e 0.5, rho 2.5 g/cm^3
#   cylinders: the paper's bed (samples/paper_dem.toml: cylinders d 5.4 l 3.8, mu 0.1, 0.27 mm)
#              against LIGGGHTS's 600 clumps of 18 spheres
# Both codes start from the same kind of pour: the peer's insert/pack places every particle at
# once in a random cloud (solid fraction 0.2 spheres, 0.15 cylinders) and lets it fall; voxpack
# does the same with --rain-height 0 and that --rain-fraction. Both stop on the same rule
# (kinetic energy below 1e-6 N m g d; --settle-speed 0 drops voxpack's extra max |v| bound,
# which one sphere rolling freely on the floor holds for seconds).
# Every timing records `uptime` load before and after; compare only the pairs of one run.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
build=${1:?build dir}
out=${2:?output dir}
which=${3:-all}
seed=${4:-1}
contact_voxels=${5:-0}
vox="$build/bin/voxpack"
mkdir -p "$out"
load() { cut -d' ' -f1-3 /proc/loadavg; }

timed() {  # NAME CMD...: wall seconds into OUT/NAME.wall, loads into OUT/NAME.load
  local name=$1
  shift
  local l0
  l0=$(load)
  /usr/bin/time -f "%e %M" -o "$out/$name.time" "$@" >"$out/$name.out" 2>"$out/$name.err"
  echo "$l0 | $(load)" >"$out/$name.load"
}

rows=()
if [[ $which == spheres || $which == all ]]; then
  PEERS_OUT="$out/liggghts" timed lig_spheres bash "$root/bench/peers/liggghts_column.sh" 2000 8 0.3 "$seed" 1
  timed vox_spheres "$vox" --threads 1 pack --mode dem --shape sphere:d=5.4 \
    --container cylinder:d=43.2,h=200 --count 2000 --friction 0.3 --restitution 0.5 \
    --density 2.5 --voxel-size 0.54 --rain-height 0 --rain-fraction 0.2 \
    --settle-speed 0 --seed "$seed" -o "$out/vox_spheres.h5"
  rows+=(spheres)
fi
if [[ $which == cylinders || $which == all ]]; then
  PEERS_OUT="$out/liggghts" SHAPE=cyl timed lig_cylinders bash "$root/bench/peers/liggghts_column.sh" 600 8 0.1 "$seed" 1
  for cv in $contact_voxels; do
    name=cylinders
    [[ $cv == 0 ]] || name=cylinders_cv$cv
    timed "vox_$name" "$vox" --threads 1 pack --config "$root/samples/paper_dem.toml" \
      --rain-height 0 --rain-fraction 0.15 --settle-speed 0 --seed "$seed" \
      --contact-voxel "$cv" -o "$out/vox_$name.h5"
    [[ $name == cylinders ]] || cp "$out/lig_cylinders.time" "$out/lig_$name.time"
    [[ $name == cylinders ]] || cp "$out/lig_cylinders.load" "$out/lig_$name.load"
    rows+=("$name")
  done
fi
/usr/bin/python3 - "$out" "$seed" "$vox" "${rows[@]}" <<'PY'
import json, subprocess, sys
out, seed, vox, rows = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4:]
res = {"what": "wall seconds (/usr/bin/time %e), one thread or process each, same run",
       "seed": seed, "scenes": {}}
for r in rows:
    def t(name):
        wall, rss = open(f"{out}/{name}.time").read().split()[-2:]
        return float(wall), int(rss), open(f"{out}/{name}.load").read().strip()
    lw, lr, ll = t(f"lig_{r}")
    vw, vr, vl = t(f"vox_{r}")
    info = json.loads(subprocess.run([vox, "info", "--json", f"{out}/vox_{r}.h5"],
                                     capture_output=True, check=True).stdout)
    dem = info["provenance"]["dem"]
    meta = json.load(open(subprocess.run(["bash", "-c", f"ls -d {out}/liggghts/liggghts_{'sphere' if r == 'spheres' else 'cyl'}_*_s{seed}_np1/run_meta.json"],
                                         capture_output=True, text=True).stdout.split()[0]))
    res["scenes"][r] = {"liggghts_wall_s": lw, "liggghts_max_rss_kb": lr, "liggghts_load_1_5_15": ll,
                        "voxpack_wall_s": vw, "voxpack_max_rss_kb": vr, "voxpack_load_1_5_15": vl,
                        "ratio_voxpack_over_liggghts": vw / lw,
                        "voxpack_status": info["provenance"]["status"],
                        "voxpack_particles": info["particles"],
                        "voxpack_simulated_s": dem["simulated_time_s"], "voxpack_steps": dem["steps"],
                        "voxpack_time_step_s": dem["time_step_s"],
                        "voxpack_contact_voxel_mm": dem.get("contact_voxel_mm"),
                        "voxpack_per_simulated_s": vw / dem["simulated_time_s"],
                        "voxpack_mean_overlap_d": dem.get("mean_overlap_d"),
                        "voxpack_density": info.get("packing_density", info.get("density")),
                        "liggghts_settled": meta.get("settled"), "liggghts_atoms": meta.get("atoms"),
                        "liggghts_time_step_s": meta.get("dt")}
    print(f"{r}: LIGGGHTS {lw:.1f} s (load {ll}), voxpack {vw:.1f} s (load {vl}), ratio {vw / lw:.2f}")
json.dump(res, open(f"{out}/dem_peers.json", "w"), indent=1)
PY
