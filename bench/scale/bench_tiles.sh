#!/usr/bin/env bash
# Streamed S2 by tiles (docs/scale.md): the same synthetic sphere bed of N³ voxels as
# bench_scale.sh, `voxpack stats --only axial,radial,s2 --s2-max-lag-mm 3.2` (h_max 64
# voxels) under --memory-limit LIMIT, once with the tile edge the budget chooses and once
# with whole planes (--s2-tile-voxels N), 2 threads. Peak RSS and CPU from /usr/bin/time -v.
# Usage: bench/scale/bench_tiles.sh BUILD_DIR WORK_DIR N LIMIT   e.g. ... 1024 2G
# Writes bench/results/scale_tiles_<N>.json. Not run by CI.
set -euo pipefail
build="$(cd "$1" && pwd)"; work="$2"; n="$3"; limit="$4"
root="$(cd "$(dirname "$0")/../.." && pwd)"
voxpack="$build/bin/voxpack"; make="$build/bin/voxpack_make_sphere_bed"
mkdir -p "$work" "$root/bench/results"
source "$root/bench/scale/run_lib.sh"
bed="$work/bed_$n.h5"; out="$root/bench/results/scale_tiles_$n.json"
[ -f "$bed" ] || { echo "generating $bed" >&2; run generate "$n" "$make" "$bed" "$n" 32 1 >"$work/gen_$n.json"; }
args=(--quiet --threads 2 --memory-limit "$limit" stats "$bed" --only axial,radial,s2
      --s2-max-lag-mm 3.2 --particle-diameter-mm "$(echo "$n/16*0.05" | bc -l)")
{
  echo "["
  cat "$work/gen_$n.json"; echo ","
  run "stats_${limit}_auto_tiles" "$n" "$voxpack" "${args[@]}" -o "$work/tiles_auto_$n.json"; echo ","
  run "stats_${limit}_whole_planes" "$n" "$voxpack" "${args[@]}" --s2-tile-voxels "$n" \
    -o "$work/tiles_whole_$n.json"
  echo "]"
} >"$out"
# What each run chose (slab planes, tile edge, FFT box, estimate) and that both agree.
/usr/bin/python3 - "$work/tiles_auto_$n.json" "$work/tiles_whole_$n.json" "$out" <<'PY'
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
runs = json.load(open(sys.argv[3]))
for r, s in zip(runs[1:], (a, b)):
    r["streamed"] = s["streamed"]
    r["fft_dims"] = s["s2"]["fft_dims"]
runs.append({"same_pairs": a["s2"]["pairs"] == b["s2"]["pairs"],
             "max_rel_s2_diff": max(abs(x - y) / max(abs(x), 1e-300)
                                    for x, y in zip(a["s2"]["s2"], b["s2"]["s2"]))})
json.dump(runs, open(sys.argv[3], "w"), indent=1)
PY
echo "wrote $out" >&2
