#!/usr/bin/env bash
# Why 2-thread runs of the paper's bed differ (docs/dem.md "Threads, 2026-12-07"):
#   bench/dem/threads_modes.sh BUILD_DIR OUT_DIR [RUNS] [GAP_S]
# One 1-thread run, then RUNS (default 5) 2-thread runs of the threads_compare.sh scene, each
# between two runs of bench/dem/compute_probe.cpp (the machine's own 2-thread efficiency,
# arithmetic only); then, after GAP_S (default 90) idle seconds each, a 1-, 2-, 2-, 1- and
# 2-thread run: does rest bring the fast runs back? Raw JSON to
# OUT_DIR/dem_threads_modes.json.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
build=${1:?build dir}
out=${2:?output dir}
runs=${3:-5}
gap=${4:-90}
mkdir -p "$out"
g++ -O3 -march=x86-64-v3 -fopenmp "$here/compute_probe.cpp" -o "$out/compute_probe"
one() {  # TAG THREADS
  bash "$here/threads_compare.sh" "$build" "$out/$1" 1 20 "$2" 1 >"$out/$1.log" 2>&1
}
one batch_t1 1
for r in $(seq "$runs"); do
  "$out/compute_probe" >"$out/batch_t2_$r.probe_before.json"
  one "batch_t2_$r" 2
  "$out/compute_probe" >"$out/batch_t2_$r.probe_after.json"
done
i=0
for t in 1 2 2 1 2; do
  i=$((i + 1))
  sleep "$gap"
  one "gap_${i}_t$t" "$t"
done
/usr/bin/python3 - "$out" "$gap" <<'PY'
import glob, json, os, statistics, sys
out, gap = sys.argv[1], float(sys.argv[2])
rows = []
for d in sorted(glob.glob(f"{out}/batch_*") + glob.glob(f"{out}/gap_*")):
    if not os.path.isdir(d):
        continue
    run = json.load(open(f"{d}/dem_threads.json"))["runs"][0]
    t = [k for k in run if k != "rep"][0]
    r = run[t]
    row = {"run": os.path.basename(d), "threads": int(t), "wall_s": r["wall_s"], "cpu_s": r["cpu_s"],
           "load_1_5_15_before_after": r["load_1_5_15_before_after"],
           "particle_table_fnv1a64": r["digest"]["particle_table_fnv1a64"]}
    for side in ("before", "after"):
        p = f"{d}.probe_{side}.json"
        if os.path.exists(p):
            row[f"probe_{side}"] = json.load(open(p))
    rows.append(row)
one = [r["wall_s"] for r in rows if r["threads"] == 1]
two = [r["wall_s"] for r in rows if r["threads"] == 2]
res = {"what": "the paper's bed (threads_compare.sh scene) on 1 and 2 threads, with a compute probe "
               "around the batch's 2-thread runs and idle gaps before the later ones",
       "gap_s": gap, "runs": rows,
       "median_1_thread_s": statistics.median(one), "median_2_threads_s": statistics.median(two),
       "speedup_of_medians": statistics.median(one) / statistics.median(two),
       "same_bits": len({r["particle_table_fnv1a64"] for r in rows}) == 1}
json.dump(res, open(f"{out}/dem_threads_modes.json", "w"), indent=1)
for r in rows:
    print(r["run"], r["threads"], r["wall_s"], r["cpu_s"],
          r.get("probe_before", {}).get("efficiency"), r.get("probe_after", {}).get("efficiency"))
print(f"median 1 thread {res['median_1_thread_s']:.1f} s, 2 threads {res['median_2_threads_s']:.1f} s: "
      f"{res['speedup_of_medians']:.2f}x, same bits {res['same_bits']}")
PY
