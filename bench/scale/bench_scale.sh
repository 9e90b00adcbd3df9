#!/usr/bin/env bash
# Scale benchmark (docs/scale.md): synthetic sphere beds of N³ written slab by slab, then
# `voxpack stats --only axial,radial,s2` (S2 h_max 64 voxels, porosity) with peak RSS from
# /usr/bin/time -v under ulimit -v, in memory and streamed, and over 1/2/4 MPI ranks.
# Usage: bench/scale/bench_scale.sh BUILD_DIR WORK_DIR [N...]   (default N: 256 512)
# Writes bench/results/scale_<N>.json (one record per run). Not run by CI.
set -euo pipefail
build="$(cd "$1" && pwd)"; work="$2"; shift 2
sizes=("${@:-256 512}"); [ $# -eq 0 ] && sizes=(256 512)
root="$(cd "$(dirname "$0")/../.." && pwd)"
voxpack="$build/bin/voxpack"; make="$build/bin/voxpack_make_sphere_bed"
mkdir -p "$work" "$root/bench/results"
vlimit_kb=$((6 * 1024 * 1024))  # never more than 6 GiB of address space
source "$root/bench/scale/run_lib.sh"
for n in "${sizes[@]}"; do
  bed="$work/bed_$n.h5"; out="$root/bench/results/scale_$n.json"
  [ -f "$bed" ] || { echo "generating $bed" >&2; run generate "$n" "$make" "$bed" "$n" 32 1 >"$work/gen_$n.json"; }
  {
    echo "["
    cat "$work/gen_$n.json"; echo ","
    run info "$n" "$voxpack" --quiet info "$bed" --json; echo ","
    args=(--quiet --threads 2 stats "$bed" --only axial,radial,s2 --s2-max-lag-mm 3.2
          --particle-diameter-mm "$(echo "$n/16*0.05" | bc -l)")
    run stats_in_memory "$n" "$voxpack" "${args[@]}" -o "$work/mem_$n.json"; echo ","
    run stats_streamed_64 "$n" "$voxpack" "${args[@]}" --slab-voxels 64 -o "$work/s64_$n.json"; echo ","
    run stats_budget_1G "$n" "$voxpack" --memory-limit 1G "${args[@]}" -o "$work/b1g_$n.json"; echo ","
    for np in 1 2 4; do
      run "stats_mpi_np$np" "$n" mpirun --oversubscribe --allow-run-as-root -np "$np" "$voxpack" \
        --quiet --threads 1 stats "$bed" --only axial,radial,s2 --s2-max-lag-mm 3.2 --slab-voxels 64 \
        -o "$work/mpi${np}_$n.json"
      [ "$np" = 4 ] || echo ","
    done
    echo "]"
  } >"$out"
  echo "wrote $out" >&2
done
