#!/usr/bin/env bash
# One thread against two on the paper's bed, back to back (docs/dem.md "Threads").
#   bench/dem/threads_compare.sh BUILD_DIR OUT_DIR [SEED] [MAX_TIME_S] [ORDER] [REPS]
# The scene is the LIGGGHTS comparison's (bench/dem/peer_compare.sh cylinders): the paper's
# 609 exact cylinders (samples/paper_dem.toml, 0.27 mm) poured from one cloud, settled on
# the peer's energy rule. MAX_TIME_S (default 20) shortens it. ORDER "1 2" (default) or
# "2 1". REPS (default 1) repeats the ORDER pair: this 2-vCPU VM's speed drifts by ~10 %
# between minutes, so one pair is one sample and the median of the pairs is reported.
# Each run: /usr/bin/time -v (wall, user, sys, max RSS), /proc/loadavg before and after,
# and the bed's bit fingerprint (dem_bed_digest), which must agree across threads and reps.
# Raw JSON to OUT_DIR/dem_threads.json.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
build=${1:?build dir}
out=${2:?output dir}
seed=${3:-1}
maxt=${4:-20}
order=${5:-1 2}
reps=${6:-1}
vox="$build/bin/voxpack"
mkdir -p "$out"
for r in $(seq "$reps"); do
  for t in $order; do
    tag="t${t}_r${r}"
    cut -d' ' -f1-3 /proc/loadavg >"$out/$tag.load"
    /usr/bin/time -v -o "$out/$tag.time" "$vox" --threads "$t" pack \
      --config "$root/samples/paper_dem.toml" --rain-height 0 --rain-fraction 0.15 \
      --settle-speed 0 --seed "$seed" --max-time "$maxt" -o "$out/$tag.h5" \
      >"$out/$tag.out" 2>"$out/$tag.err"
    cut -d' ' -f1-3 /proc/loadavg >>"$out/$tag.load"
    "$build/bin/dem_bed_digest" "$out/$tag.h5" >"$out/$tag.digest.json"
    "$vox" info --json "$out/$tag.h5" >"$out/$tag.info.json"
    rm -f "$out/$tag.h5"
  done
done
/usr/bin/python3 - "$out" "$seed" "$maxt" "$order" "$reps" "$(printf '%q ' "$@")" <<'PY'
import json, re, statistics, sys
out, seed, maxt, order, reps, args = (sys.argv[1], int(sys.argv[2]), float(sys.argv[3]),
                                      sys.argv[4].split(), int(sys.argv[5]), sys.argv[6])
def tv(path):
    txt = open(path).read()
    get = lambda key: re.search(re.escape(key) + r":\s*(.+)", txt).group(1).strip()
    h, m, s = (["0"] + get("Elapsed (wall clock) time (h:mm:ss or m:ss)").split(":"))[-3:]
    return {"wall_s": 3600 * float(h) + 60 * float(m) + float(s),
            "user_s": float(get("User time (seconds)")), "sys_s": float(get("System time (seconds)")),
            "max_rss_kb": int(get("Maximum resident set size (kbytes)"))}
res = {"what": "paper bed (samples/paper_dem.toml, one cloud, peer's settle rule), 1 vs 2 threads back to back",
       "command": "bench/dem/threads_compare.sh " + args.strip(), "seed": seed, "max_time_s": maxt,
       "order": order, "reps": reps, "runs": []}
digests = set()
for rep in range(1, reps + 1):
    row = {"rep": rep}
    for t in order:
        tag = f"t{t}_r{rep}"
        r = tv(f"{out}/{tag}.time")
        r["cpu_s"] = r["user_s"] + r["sys_s"]
        r["load_1_5_15_before_after"] = open(f"{out}/{tag}.load").read().split("\n")[:2]
        dem = json.load(open(f"{out}/{tag}.info.json"))["provenance"]
        r["status"] = dem["status"]
        r["simulated_time_s"] = dem["dem"]["simulated_time_s"]
        r["steps"] = dem["dem"]["steps"]
        r["digest"] = json.load(open(f"{out}/{tag}.digest.json"))
        digests.add(json.dumps(r["digest"], sort_keys=True))
        row[t] = r
    if "1" in row and "2" in row:
        row["speedup_wall_2_over_1"] = row["1"]["wall_s"] / row["2"]["wall_s"]
        row["cpu_ratio_2_over_1"] = row["2"]["cpu_s"] / row["1"]["cpu_s"]
        print(f"rep {rep}: 1 thread {row['1']['wall_s']:.1f} s wall ({row['1']['cpu_s']:.1f} s CPU), "
              f"2 threads {row['2']['wall_s']:.1f} s wall ({row['2']['cpu_s']:.1f} s CPU): "
              f"speed-up {row['speedup_wall_2_over_1']:.2f}x")
    res["runs"].append(row)
res["same_bits"] = len(digests) == 1
sp = [row["speedup_wall_2_over_1"] for row in res["runs"] if "speedup_wall_2_over_1" in row]
if sp:
    res["speedup_wall_2_over_1_median"] = statistics.median(sp)
    res["speedup_wall_2_over_1_range"] = [min(sp), max(sp)]
    print(f"speed-up median {res['speedup_wall_2_over_1_median']:.2f}x (range {min(sp):.2f}-{max(sp):.2f}, "
          f"{len(sp)} pairs), same bits {res['same_bits']}")
json.dump(res, open(f"{out}/dem_threads.json", "w"), indent=1)
PY
