#!/usr/bin/env bash
# One thread against two on the paper's bed, back to back (docs/dem.md "Threads").
#   bench/dem/threads_compare.sh BUILD_DIR OUT_DIR [SEED] [MAX_TIME_S] [ORDER]
# The scene is the LIGGGHTS comparison's (bench/dem/peer_compare.sh cylinders): the paper's
# 609 exact cylinders (samples/paper_dem.toml, 0.27 mm) poured from one cloud, settled on
# the peer's energy rule. MAX_TIME_S (default 20) shortens it. ORDER "1 2" (default) or
# "2 1". Each run: /usr/bin/time -v (wall, user, sys, max RSS), /proc/loadavg before and
# after, and the bed's bit fingerprint (dem_bed_digest), which must agree across threads.
# Raw JSON to OUT_DIR/dem_threads.json.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
build=${1:?build dir}
out=${2:?output dir}
seed=${3:-1}
maxt=${4:-20}
order=${5:-1 2}
vox="$build/bin/voxpack"
mkdir -p "$out"
for t in $order; do
  cut -d' ' -f1-3 /proc/loadavg >"$out/t$t.load"
  /usr/bin/time -v -o "$out/t$t.time" "$vox" --threads "$t" pack \
    --config "$root/samples/paper_dem.toml" --rain-height 0 --rain-fraction 0.15 \
    --settle-speed 0 --seed "$seed" --max-time "$maxt" -o "$out/t$t.h5" \
    >"$out/t$t.out" 2>"$out/t$t.err"
  cut -d' ' -f1-3 /proc/loadavg >>"$out/t$t.load"
  "$build/bin/dem_bed_digest" "$out/t$t.h5" >"$out/t$t.digest.json"
  "$vox" info --json "$out/t$t.h5" >"$out/t$t.info.json"
done
/usr/bin/python3 - "$out" "$seed" "$maxt" "$order" "$(printf '%q ' "$@")" <<'PY'
import json, re, sys
out, seed, maxt, order, args = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), sys.argv[4].split(), sys.argv[5]
def tv(path):
    txt = open(path).read()
    get = lambda key: re.search(re.escape(key) + r":\s*(.+)", txt).group(1).strip()
    h, m, s = (["0"] + get("Elapsed (wall clock) time (h:mm:ss or m:ss)").split(":"))[-3:]
    return {"wall_s": 3600 * float(h) + 60 * float(m) + float(s),
            "user_s": float(get("User time (seconds)")), "sys_s": float(get("System time (seconds)")),
            "max_rss_kb": int(get("Maximum resident set size (kbytes)"))}
res = {"what": "paper bed (samples/paper_dem.toml, one cloud, peer's settle rule), 1 vs 2 threads back to back",
       "command": "bench/dem/threads_compare.sh " + args.strip(), "seed": seed, "max_time_s": maxt, "order": order, "runs": {}}
for t in order:
    r = tv(f"{out}/t{t}.time")
    r["cpu_s"] = r["user_s"] + r["sys_s"]
    r["load_1_5_15_before_after"] = open(f"{out}/t{t}.load").read().split("\n")[:2]
    dem = json.load(open(f"{out}/t{t}.info.json"))["provenance"]
    r["status"] = dem["status"]
    r["simulated_time_s"] = dem["dem"]["simulated_time_s"]
    r["steps"] = dem["dem"]["steps"]
    r["digest"] = json.load(open(f"{out}/t{t}.digest.json"))
    res["runs"][t] = r
if "1" in res["runs"] and "2" in res["runs"]:
    a, b = res["runs"]["1"], res["runs"]["2"]
    res["speedup_wall_2_over_1"] = a["wall_s"] / b["wall_s"]
    res["cpu_ratio_2_over_1"] = b["cpu_s"] / a["cpu_s"]
    res["same_bits"] = a["digest"] == b["digest"]
    print(f"1 thread {a['wall_s']:.1f} s wall ({a['cpu_s']:.1f} s CPU), 2 threads {b['wall_s']:.1f} s wall "
          f"({b['cpu_s']:.1f} s CPU): speed-up {res['speedup_wall_2_over_1']:.2f}x, same bits {res['same_bits']}")
json.dump(res, open(f"{out}/dem_threads.json", "w"), indent=1)
PY
