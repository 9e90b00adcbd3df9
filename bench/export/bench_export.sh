#!/usr/bin/env bash
# Export speed on the paper's bed (~650 cylinders d 5.4 x l 3.8 mm, 43.3 mm column, MC):
# packs it once at a coarse voxel (0.54 mm: the surfaces depend on the poses only), then
# times `voxpack export` to STL for each contact treatment and to the volume formats, on
# 2 threads, and writes bench/results/export_paper.json (wall seconds, output bytes, load).
# Usage: bench/export/bench_export.sh [BUILD_DIR]   (default build)
set -euo pipefail
here="$(cd "$(dirname "$0")/../.." && pwd)"
build="${1:-$here/build}"
vp="$build/bin/voxpack"
work="${VOXPACK_BENCH_DIR:-/tmp/voxpack_bench_export}"
mkdir -p "$work" "$here/bench/results"
bed="$work/paper_mc.h5"
if [ ! -f "$bed" ]; then
  "$vp" pack --config "$here/samples/paper_mc.toml" --voxel-size 0.54 -o "$bed" --quiet --threads 2
fi
load() { cut -d' ' -f1-3 /proc/loadavg; }
entries=()
run() {  # name format extra...
  local name="$1" fmt="$2"; shift 2
  local out="$work/$name.$fmt"
  [ "$fmt" = tiff ] && out="$work/${name}_tiff"
  local l0; l0="$(load)"
  local t0; t0=$(date +%s.%N)
  /usr/bin/time -v -o "$work/$name.time" "$vp" export "$bed" --format "$fmt" -o "$out" \
      --threads 2 --json --quiet "$@" > "$work/$name.json"
  local t1; t1=$(date +%s.%N)
  local rss; rss=$(awk -F: '/Maximum resident/ {gsub(/ /,"",$2); print $2}' "$work/$name.time")
  local bytes; bytes=$(du -sb "$out" | cut -f1)
  local tris; tris=$(python3 -c "import json;print(json.load(open('$work/$name.json')).get('triangles', 'null'))")
  entries+=("{\"name\": \"$name\", \"format\": \"$fmt\", \"args\": \"$*\", \"wall_s\": $(echo "$t1 - $t0" | bc), \"bytes\": $bytes, \"triangles\": $tris, \"peak_rss_kb\": $rss, \"load_before\": \"$l0\"}")
  echo "${entries[-1]}"
}
run stl_none stl
run stl_none_fine stl --tolerance-mm 0.0054
run obj_none obj
run stl_gap stl --contacts gap
run stl_cap stl --contacts cap
run stl_bridge stl --contacts bridge
run xdmf xdmf
run vtkhdf vtkhdf
run vtk vtk
run csv csv
run nrrd nrrd
run tiff tiff
{
  echo "{"
  echo "  \"what\": \"voxpack export of the paper MC bed (samples/paper_mc.toml packed at 0.54 mm), 2 threads, wall seconds of the whole command incl. reading the bed\","
  echo "  \"bed\": \"$bed\", \"particles\": $("$vp" info "$bed" --json | python3 -c 'import json,sys;print(json.load(sys.stdin)["particles"])'),"
  echo "  \"host_cores\": $(nproc), \"date\": \"$(date -u +%FT%TZ)\","
  echo "  \"runs\": ["
  for i in "${!entries[@]}"; do
    sep=","; [ "$i" -eq $((${#entries[@]} - 1)) ] && sep=""
    echo "    ${entries[$i]}$sep"
  done
  echo "  ]"
  echo "}"
} > "$here/bench/results/export_paper.json"
echo "wrote $here/bench/results/export_paper.json"
