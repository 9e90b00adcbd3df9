#!/usr/bin/env bash
# Streamed mean empty space (docs/scale.md): an N³ (default 512³) synthetic sphere bed with a
# mask, `voxpack stats --only mes` in memory, then streamed under MES_LIMITS (default
# "300M 200M"): peak RSS, CPU, the plan (slab, halo, estimate) and whether the streamed JSON
# equals the in-memory one. Usage: bench/scale/bench_mes.sh BUILD WORK [N]. Writes
# bench/results/scale_mes_<N>.json. Not run by CI.
set -euo pipefail
build="$(cd "$1" && pwd)"; work="$2"; n="${3:-512}"
root="$(cd "$(dirname "$0")/../.." && pwd)"
voxpack="$build/bin/voxpack"; make="$build/bin/voxpack_make_sphere_bed"
mkdir -p "$work" "$root/bench/results"
vlimit_kb=$((8 * 1024 * 1024))
source "$root/bench/scale/run_lib.sh"
out="$root/bench/results/scale_mes_$n.json"; bed="$work/mes_bed_$n.h5"
threads="${THREADS:-1}"
{
  echo "{\"commit\":\"$(git -C "$root" rev-parse --short HEAD)\",\"n\":$n,\"threads\":$threads,\"runs\":["
  run generate_bed "$n" "$make" "$bed" "$n" 32 1; echo ","
  run mes_in_memory "$n" "$voxpack" --quiet --threads "$threads" stats "$bed" --only mes \
    -o "$work/mes_mem_$n.json"
  for lim in ${MES_LIMITS:-300M 200M}; do
    echo ","
    run "mes_streamed_$lim" "$n" "$voxpack" --quiet --threads "$threads" --memory-limit "$lim" \
      stats "$bed" --only mes -o "$work/mes_${lim}_${n}.json"
  done
  echo "]}"
} >"$out.partial"
mv "$out.partial" "$out"
/usr/bin/python3 "$root/bench/scale/mes_summary.py" "$work" "$out"
[ "${KEEP:-0}" = 1 ] || rm -f "$bed"
echo "wrote $out" >&2
