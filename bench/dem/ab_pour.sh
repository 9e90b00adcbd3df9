#!/usr/bin/env bash
# Two voxpack binaries on the peer cylinder scene (peer_compare.sh: samples/paper_dem.toml,
# one cloud at 0.15, --settle-speed 0, seed 1), THREADS (default 1) threads, full pour,
# alternated A B A B... so that this VM's drift (+-10 % within minutes) falls on both. Copy the binaries out of
# the build first. Checks that both beds have the same particle table (a speed change must
# not change the bed). Raw JSON to OUT/dem_ab_pour.json.
#   bench/dem/ab_pour.sh BIN_A BIN_B OUT_DIR [REPS=2] [EXTRA PACK ARGS...]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
a=${1:?binary A}
b=${2:?binary B}
out=${3:?output dir}
reps=${4:-2}
shift $(($# < 4 ? $# : 4))
digest=${DIGEST:-$root/build/bin/dem_bed_digest}
[[ -x $digest ]] || { echo "error: build dem_bed_digest (or set DIGEST)" >&2; exit 2; }
threads=${THREADS:-1}
mkdir -p "$out"
rows=()
for rep in $(seq 1 "$reps"); do
  for v in A B; do
    bin=$a
    [[ $v == B ]] && bin=$b
    name="${v}_${rep}"
    l0=$(cut -d' ' -f1-3 /proc/loadavg)
    /usr/bin/time -f "%e %U %M" -o "$out/$name.time" "$bin" --threads "$threads" pack \
      --config "$root/samples/paper_dem.toml" --rain-height 0 --rain-fraction 0.15 \
      --settle-speed 0 --seed 1 "$@" -o "$out/$name.h5" >"$out/$name.out" 2>"$out/$name.err"
    l1=$(cut -d' ' -f1-3 /proc/loadavg)
    "$digest" "$out/$name.h5" >"$out/$name.digest.json"
    rows+=("$v" "$rep" "$l0 | $l1")
    echo "$name: $(cut -d' ' -f1 "$out/$name.time") s wall" >&2
    rm -f "$out/$name.h5"
  done
done
/usr/bin/python3 - "$out" "$a" "$b" "$threads" "${rows[@]}" <<'PY'
import json, statistics, sys
out, a, b, threads = sys.argv[1:5]
rest = sys.argv[5:]
runs = []
for i in range(0, len(rest), 3):
    v, rep, load = rest[i:i + 3]
    wall, user, rss = open(f"{out}/{v}_{rep}.time").read().split()[-3:]
    dg = json.load(open(f"{out}/{v}_{rep}.digest.json"))
    runs.append({"variant": v, "binary": a if v == "A" else b, "rep": int(rep),
                 "wall_s": float(wall), "cpu_user_s": float(user), "max_rss_kb": int(rss),
                 "load_1_5_15_before_after": load,
                 "particle_table_fnv1a64": dg["particle_table_fnv1a64"]})
wa = [r["wall_s"] for r in runs if r["variant"] == "A"]
wb = [r["wall_s"] for r in runs if r["variant"] == "B"]
pairs = [rb / ra for ra, rb in zip(wa, wb)]
res = {"scene": "peer cylinders (samples/paper_dem.toml, --rain-height 0 --rain-fraction 0.15 "
                "--settle-speed 0 --seed 1), full pour, A B alternated",
       "threads": int(threads),
       "runs": runs, "median_A_s": statistics.median(wa), "median_B_s": statistics.median(wb),
       "pair_ratios_B_over_A": pairs, "median_ratio_B_over_A": statistics.median(pairs),
       "same_bed": len({r["particle_table_fnv1a64"] for r in runs}) == 1}
json.dump(res, open(f"{out}/dem_ab_pour.json", "w"), indent=1)
print(f"B/A: pairs {', '.join(f'{p:.3f}' for p in pairs)}, median {res['median_ratio_B_over_A']:.3f}; "
      f"same bed: {res['same_bed']}")
PY
