#!/usr/bin/env bash
# What coarser contact nodes cost in accuracy (docs/dem.md "Contact nodes coarser than the
# lattice"): the paper's bed poured as in the LIGGGHTS comparison (samples/paper_dem.toml, one
# cloud, the peer's energy rule), digitised at 0.27 mm every time, contact nodes at each
# --contact-voxel value (0 = 0.27 mm), over several seeds.
#   bench/dem/contact_voxel.sh BUILD_DIR OUT_DIR ["SEEDS"] ["CONTACT_VOXELS"] [THREADS]
# Defaults: seeds "1 2 3", contact voxels "0 0.36 0.45", 2 threads. Per bed: wall and CPU
# time, settle time, mean overlap, and dem_bed_density's window density (2 d above the floor
# to 2 d below the top) and core density (r < R - 2 d). Raw JSON to OUT_DIR/dem_contact_voxel.json.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
build=${1:?build dir}
out=${2:?output dir}
seeds=${3:-1 2 3}
cvs=${4:-0 0.36 0.45}
threads=${5:-2}
vox="$build/bin/voxpack"
mkdir -p "$out"
for seed in $seeds; do
  for cv in $cvs; do
    name="s${seed}_cv${cv}"
    cut -d' ' -f1-3 /proc/loadavg >"$out/$name.load"
    /usr/bin/time -f "%e %U %M" -o "$out/$name.time" "$vox" --threads "$threads" pack \
      --config "$root/samples/paper_dem.toml" --rain-height 0 --rain-fraction 0.15 \
      --settle-speed 0 --seed "$seed" --contact-voxel "$cv" -o "$out/$name.h5" \
      >"$out/$name.out" 2>"$out/$name.err"
    cut -d' ' -f1-3 /proc/loadavg >>"$out/$name.load"
    "$vox" info --json "$out/$name.h5" >"$out/$name.info.json"
    "$build/bin/dem_bed_density" "$out/$name.h5" 5.4 >"$out/$name.density.json"
    rm -f "$out/$name.h5"
  done
done
/usr/bin/python3 - "$out" "$seeds" "$cvs" "$threads" <<'PY'
import json, statistics, sys
out, seeds, cvs, threads = sys.argv[1], sys.argv[2].split(), sys.argv[3].split(), int(sys.argv[4])
rows = []
for seed in seeds:
    for cv in cvs:
        b = f"{out}/s{seed}_cv{cv}"
        wall, user, rss = open(b + ".time").read().split()[-3:]
        dem = json.load(open(b + ".info.json"))["provenance"]["dem"]
        dens = json.load(open(b + ".density.json"))
        rows.append({"seed": int(seed), "contact_voxel_arg": cv,
                     "contact_voxel_mm": dem["contact_voxel_mm"], "wall_s": float(wall),
                     "cpu_user_s": float(user), "max_rss_kb": int(rss),
                     "load_before_after": open(b + ".load").read().split("\n")[:2],
                     "status": json.load(open(b + ".info.json"))["provenance"]["status"],
                     "simulated_s": dem["simulated_time_s"], "mean_overlap_d": dem["mean_overlap_d"],
                     "window_density": dens["density_cross_section"], "core_density": dens["core_density"],
                     "axial_std": dens["axial_std"]})
summary = {}
for cv in cvs:
    sel = [r for r in rows if r["contact_voxel_arg"] == cv]
    w = [r["window_density"] for r in sel]
    c = [r["core_density"] for r in sel]
    summary[cv] = {"contact_voxel_mm": sel[0]["contact_voxel_mm"], "beds": len(sel),
                   "window_density_mean": statistics.mean(w),
                   "window_density_sd": statistics.stdev(w) if len(w) > 1 else None,
                   "core_density_mean": statistics.mean(c),
                   "core_density_sd": statistics.stdev(c) if len(c) > 1 else None,
                   "wall_s_mean": statistics.mean(r["wall_s"] for r in sel),
                   "mean_overlap_d_mean": statistics.mean(r["mean_overlap_d"] for r in sel)}
    s = summary[cv]
    print(f"contact voxel {s['contact_voxel_mm']} mm: window {s['window_density_mean']:.4f} "
          f"(sd {s['window_density_sd'] or 0:.4f}), core {s['core_density_mean']:.4f} "
          f"(sd {s['core_density_sd'] or 0:.4f}), {s['wall_s_mean']:.1f} s wall, "
          f"overlap {s['mean_overlap_d_mean']:.4f} d, {s['beds']} beds")
json.dump({"what": "paper bed, peer's pour, contact nodes at several spacings (bench/dem/contact_voxel.sh)",
           "threads": threads, "beds": rows, "summary": summary},
          open(f"{out}/dem_contact_voxel.json", "w"), indent=1)
PY
