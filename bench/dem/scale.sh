#!/usr/bin/env bash
# The multi-tube reactor scale case of issue 18 (docs/dem.md "Scale"): cylinders d 2 mm,
# l 2 mm (d_pe 2.29 mm) poured into a tube of D 11.5 mm (D/d_pe 5), 0.2 mm voxels (10 per d),
# default rain, 2 threads. COUNTS particles each (default "1000 10000"; the tube is made
# long enough for each: 10^4 fill ~1.1 m). MAX_TIME_S caps the simulated time (default 20).
#   bench/dem/scale.sh BUILD_DIR OUT_DIR ["COUNTS"] [MAX_TIME_S] [THREADS]
# Per run: wall and CPU (/usr/bin/time), max RSS, status, simulated time, particle-steps
# and the wall seconds per particle-step (all, and integrated ones), so the cost can be
# compared from 10^3 to 10^4 particles even when the cap stops a run. Raw JSON to
# OUT_DIR/dem_scale.json.
set -euo pipefail
build=${1:?build dir}
out=${2:?output dir}
counts=${3:-1000 10000}
maxt=${4:-20}
threads=${5:-2}
vox="$build/bin/voxpack"
mkdir -p "$out"
for n in $counts; do
  # ~0.55 solid fraction of a 11.5 mm tube: 6.28 mm^3 a cylinder -> 0.11 mm of tube each.
  h=$(/usr/bin/python3 -c "print(int($n * 6.2832 / (0.55 * 3.14159 * 5.75 ** 2) * 1.15 + 20))")
  cut -d' ' -f1-3 /proc/loadavg >"$out/n$n.load"
  /usr/bin/time -f "%e %U %M" -o "$out/n$n.time" "$vox" --threads "$threads" pack --mode dem \
    --shape cylinder:d=2,l=2 --container "cylinder:d=11.5,h=$h" --voxel-size 0.2 --count "$n" \
    --friction 0.3 --restitution 0.5 --seed 1 --max-time "$maxt" -o "$out/n$n.h5" \
    >"$out/n$n.out" 2>"$out/n$n.err" || true
  cut -d' ' -f1-3 /proc/loadavg >>"$out/n$n.load"
  "$vox" info --json "$out/n$n.h5" >"$out/n$n.info.json"
  rm -f "$out/n$n.h5"
done
/usr/bin/python3 - "$out" "$counts" "$maxt" "$threads" <<'PY'
import json, sys
out, counts, maxt, threads = sys.argv[1], sys.argv[2].split(), float(sys.argv[3]), int(sys.argv[4])
rows = []
for n in counts:
    b = f"{out}/n{n}"
    wall, user, rss = open(b + ".time").read().split()[-3:]
    info = json.load(open(b + ".info.json"))
    dem = info["provenance"]["dem"]
    ps, ips = dem["particle_steps"], dem["integrated_particle_steps"]
    rows.append({"count": int(n), "status": info["provenance"]["status"], "particles": info["particles"],
                 "wall_s": float(wall), "cpu_user_s": float(user), "max_rss_kb": int(rss),
                 "load_before_after": open(b + ".load").read().split("\n")[:2],
                 "simulated_time_s": dem["simulated_time_s"], "steps": dem["steps"],
                 "dem_wall_time_s": dem["dem_wall_time_s"], "particle_steps": ps,
                 "integrated_particle_steps": ips,
                 "us_per_particle_step": 1e6 * dem["dem_wall_time_s"] / max(1, ps),
                 "us_per_integrated_particle_step": 1e6 * dem["dem_wall_time_s"] / max(1, ips)})
    r = rows[-1]
    print(f"{n}: {r['status']}, {r['wall_s']:.0f} s wall, {r['max_rss_kb'] / 1024:.0f} MiB, "
          f"{r['simulated_time_s']:.2f} s simulated, {r['us_per_particle_step']:.3f} us per particle-step "
          f"({r['us_per_integrated_particle_step']:.3f} per integrated one)")
json.dump({"what": "multi-tube scale case (bench/dem/scale.sh)", "threads": threads,
           "max_time_s": maxt, "runs": rows}, open(f"{out}/dem_scale.json", "w"), indent=1)
PY
