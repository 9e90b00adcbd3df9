#!/usr/bin/env bash
# The scale issue's big run (docs/scale.md): on this 2-core machine, an N³ (default 2048³)
#  1. synthetic sphere bed, `voxpack stats --only axial,radial,s2 --s2-max-lag-mm 3.2`
#     (h_max 64 voxels, porosity) under --memory-limit STATS_LIMIT (default 6G): streamed,
#     S2 tiles chosen from the budget;
#  2. synthetic uint8 XMT volume (attached raw NRRD, N³ bytes, written slab by slab by
#     make_grey_nrrd.py), `voxpack ingest --threshold otsu --column ...` under
#     --memory-limit INGEST_LIMIT (default 4G): streamed.
# Peak RSS, wall and CPU from /usr/bin/time -v under ulimit -v 8 GiB. Run the same script
# at 256 for the per-voxel baseline. Usage: bench/scale/bench_big.sh BUILD WORK [N]
# MPI_RANKS="1 2 4" then repeats the stats run under mpirun with that many ranks (1 thread
# each; --memory-limit STATS_LIMIT/np per rank, so the machine's total stays STATS_LIMIT).
# Writes bench/results/scale_big_<N>.json (through a .partial file, so an interrupted run
# leaves the committed result alone). Not run by CI. The inputs are deleted at the end
# (KEEP=1 keeps them).
set -euo pipefail
build="$(cd "$1" && pwd)"; work="$2"; n="${3:-2048}"
stats_limit="${STATS_LIMIT:-6G}"; ingest_limit="${INGEST_LIMIT:-4G}"
root="$(cd "$(dirname "$0")/../.." && pwd)"
voxpack="$build/bin/voxpack"; make="$build/bin/voxpack_make_sphere_bed"
mkdir -p "$work" "$root/bench/results"
vlimit_kb=$((8 * 1024 * 1024))
source "$root/bench/scale/run_lib.sh"
out="$root/bench/results/scale_big_$n.json"
bed="$work/big_bed_$n.h5"; grey="$work/big_grey_$n.nrrd"
d="$(echo "$n/16*0.05" | bc -l)"
c="$(echo "0.5*($n-1)*0.1" | bc -l)"; r="$(echo "0.47*$n*0.1" | bc -l)"
commit="$(git -C "$root" rev-parse --short HEAD)"
{
  echo "{\"commit\":\"$commit\",\"n\":$n,\"threads\":2,\"stats_limit\":\"$stats_limit\",\"ingest_limit\":\"$ingest_limit\",\"runs\":["
  run generate_bed "$n" "$make" "$bed" "$n" 32 1; echo ","
  run stats_streamed "$n" "$voxpack" --quiet --threads 2 --memory-limit "$stats_limit" stats "$bed" \
    --only axial,radial,s2 --s2-max-lag-mm 3.2 --particle-diameter-mm "$d" -o "$work/big_stats_$n.json"
  echo ","
  run generate_grey "$n" /usr/bin/python3 "$root/bench/scale/make_grey_nrrd.py" "$n" "$grey" 1; echo ","
  run ingest_streamed "$n" "$voxpack" --quiet --threads 2 --memory-limit "$ingest_limit" ingest "$grey" \
    --threshold otsu --column "$c,$c,$r" -o "$work/big_ingested_$n.h5" --json
  limit_mb="$(numfmt --from=iec "$stats_limit")"; limit_mb=$((limit_mb / 1048576))
  for np in ${MPI_RANKS:-}; do
    echo ","
    run "stats_mpi_np$np" "$n" mpirun --oversubscribe --allow-run-as-root -np "$np" "$voxpack" \
      --quiet --threads 1 --memory-limit "$((limit_mb / np))M" stats "$bed" \
      --only axial,radial,s2 --s2-max-lag-mm 3.2 --particle-diameter-mm "$d" -o "$work/big_mpi${np}_$n.json"
  done
  echo "]}"
} >"$out.partial"
mv "$out.partial" "$out"
# What the stats run chose (slabs, tiles, FFT box, estimate) and its porosity.
/usr/bin/python3 - "$work/big_stats_$n.json" "$out" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); o = json.load(open(sys.argv[2]))
o["stats_streamed"] = s.get("streamed"); o["stats_fft_dims"] = s["s2"]["fft_dims"]
o["stats_memory_estimate"] = s.get("memory_estimate_bytes"); o["porosity"] = s.get("porosity")
import os
for r in o["runs"]:  # the MPI runs against the one-process run: same values?
    if r["run"].startswith("stats_mpi_np"):
        f = os.path.join(os.path.dirname(sys.argv[1]), "big_mpi%s_%d.json" % (r["run"][12:], o["n"]))
        if os.path.exists(f):
            m = json.load(open(f))
            r["porosity"] = m.get("porosity")
            r["s2_pairs_equal_to_one_process"] = m["s2"].get("pairs") == s["s2"].get("pairs")
            r["s2_equal_to_one_process"] = m["s2"].get("s2") == s["s2"].get("s2")
for r in o["runs"]:
    r["cpu_us_per_voxel"] = (r["user_s"] + r["sys_s"]) * 1e6 / r["voxels"]
json.dump(o, open(sys.argv[2], "w"), indent=1)
PY
[ "${KEEP:-0}" = 1 ] || rm -f "$bed" "$grey" "$work/big_ingested_$n.h5"
echo "wrote $out" >&2
