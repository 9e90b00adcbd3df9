#!/usr/bin/env bash
# The README's headline densities of the paper's scene (samples/paper_dem.toml, 0.27 mm):
# poured (seeds 1, 2, 3) and after 10 taps (seed 1), each measured with the CLI alone:
#   voxpack pack --config samples/paper_dem.toml --seed S [--tap-cycles 10] -o BED.h5
#   voxpack stats BED.h5 --only axial --bed-window --particle-diameter-mm 5.4 -o STATS.json
# and written, with seed, taps, density, wall and CPU time (/usr/bin/time), threads, load
# (uptime before and after) and the git commit, to one JSON (default
# bench/results/headline_paper_dem.json). Not run by ctest: 30-60 minutes on 2 cores.
#   bench/headline/headline.sh BUILD_DIR OUT_DIR [RESULT_JSON]
# Env: THREADS (default 2), RUNS (default "1:0 2:0 3:0 1:10", seed:taps, run in that order,
# one at a time), PACK_EXTRA (more pack options, e.g. "--voxel-size 0.54" for a quick check
# of the script; recorded in the JSON). The JSON is rewritten after every run, so an unfinished set keeps the
# runs that finished.
set -euo pipefail
build=${1:?build dir}
out=${2:?output dir}
repo=$(cd "$(dirname "$0")/../.." && pwd)
result=${3:-$repo/bench/results/headline_paper_dem.json}
threads=${THREADS:-2}
runs=${RUNS:-"1:0 2:0 3:0 1:10"}
d=5.4
vox="$build/bin/voxpack"
mkdir -p "$out"
cd "$repo"

commit=$(git rev-parse HEAD)
# Source files changed but not committed would make the commit a lie: record them.
dirty=$(git status --porcelain --untracked-files=no | wc -l)
version=$("$vox" --version)
niceness=$(nice)
extra=${PACK_EXTRA:-}
: >"$out/runs.jsonl"

for run in $runs; do
  seed=${run%%:*}
  taps=${run##*:}
  name="paper_0.27_s${seed}_tap${taps}"
  load_before=$(uptime)
  args=(--threads "$threads" pack --config samples/paper_dem.toml --seed "$seed")
  if [[ $taps != 0 ]]; then args+=(--tap-cycles "$taps"); fi
  # shellcheck disable=SC2206
  if [[ -n $extra ]]; then args+=($extra); fi
  /usr/bin/time -f "%e %U %S" -o "$out/$name.pack.time" "$vox" "${args[@]}" \
    -o "$out/$name.h5" >"$out/$name.pack.out" 2>"$out/$name.pack.err"
  /usr/bin/time -f "%e %U %S" -o "$out/$name.stats.time" "$vox" --threads "$threads" stats \
    "$out/$name.h5" --only axial --bed-window --particle-diameter-mm "$d" \
    -o "$out/$name.stats.json" >"$out/$name.stats.out" 2>"$out/$name.stats.err"
  load_after=$(uptime)
  "$vox" info --json "$out/$name.h5" >"$out/$name.info.json"
  /usr/bin/python3 - "$out/$name" "$seed" "$taps" "$threads" "$load_before" "$load_after" \
    "${args[*]} -o $name.h5" >>"$out/runs.jsonl" <<'PY'
import json, sys
base, seed, taps, threads, before, after, cmd = sys.argv[1:8]
def times(path):
    wall, user, sys_ = (float(x) for x in open(path).read().split()[-3:])
    return {"wall_s": wall, "cpu_s": round(user + sys_, 2)}
def load(s):  # the three load averages of an uptime line
    return [float(x) for x in s.split("load average:")[1].split(",")]
st = json.load(open(base + ".stats.json"))
info = json.load(open(base + ".info.json"))
prov = info.get("provenance", {})
dem = prov.get("dem", {})
print(json.dumps({
    "seed": int(seed),
    "tap_cycles": int(taps),
    "packing_density": st["packing_density"],
    "axial_mean": st["axial"]["mean"],
    "axial_std": st["axial"]["std"],
    "bed_window_mm": st["roi_mm"],
    "particles": info.get("particles"),
    "status": prov.get("status"),
    "simulated_time_s": dem.get("simulated_time_s"),
    "pack": times(base + ".pack.time"),
    "stats": times(base + ".stats.time"),
    "threads": int(threads),
    "uptime_before": before.strip(),
    "uptime_after": after.strip(),
    "load_before": load(before),
    "load_after": load(after),
    "pack_command": "voxpack " + cmd,
}))
PY
  /usr/bin/python3 - "$out/runs.jsonl" "$result" "$commit" "$dirty" "$version" "$threads" \
    "$niceness" "$extra" <<'PY'
import json, statistics, sys
lines, result, commit, dirty, version, threads, niceness, extra = sys.argv[1:9]
runs = [json.loads(l) for l in open(lines) if l.strip()]
poured = [r["packing_density"] for r in runs if r["tap_cycles"] == 0]
tapped = [r["packing_density"] for r in runs if r["tap_cycles"] > 0]
summary = {}
if poured:
    summary["poured_mean"] = statistics.mean(poured)
    summary["poured_seeds"] = [r["seed"] for r in runs if r["tap_cycles"] == 0]
    if len(poured) > 1:
        summary["poured_std"] = statistics.stdev(poured)
if tapped:
    summary["tapped"] = tapped
json.dump({
    "scene": "samples/paper_dem.toml (cylinders d 5.4 x l 3.8 mm, 43.3 mm column, 0.27 mm)",
    "density": "packing_density of voxpack stats BED --only axial --bed-window "
               "--particle-diameter-mm 5.4 (docs/stats.md)",
    "git_commit": commit,
    "tracked_files_modified": int(dirty),
    "voxpack_version": version,
    "threads": int(threads),
    "niceness": int(niceness),
    "pack_extra_options": extra,
    "note": "one pack at a time; the load averages of each run say how shared the 2 cores were",
    "summary": summary,
    "runs": runs,
}, open(result, "w"), indent=1)
print(json.dumps(runs[-1]))
PY
done
