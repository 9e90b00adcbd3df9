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
# STAGES (default "stats ingest") picks the one-process runs; STAGES=none with MPI_RANKS
# runs only the rank series (its bed is generated either way).
# Writes bench/results/scale_big_<N><TAG>.json (TAG default empty; through a .partial file,
# so an interrupted run leaves the committed result alone). Not run by CI. The inputs are
# deleted at the end (KEEP=1 keeps them).
set -euo pipefail
build="$(cd "$1" && pwd)"; work="$2"; n="${3:-2048}"
stats_limit="${STATS_LIMIT:-6G}"; ingest_limit="${INGEST_LIMIT:-4G}"
root="$(cd "$(dirname "$0")/../.." && pwd)"
voxpack="$build/bin/voxpack"; make="$build/bin/voxpack_make_sphere_bed"
mkdir -p "$work" "$root/bench/results"
vlimit_kb=$((8 * 1024 * 1024))
source "$root/bench/scale/run_lib.sh"
stages=" ${STAGES:-stats ingest} "
out="$root/bench/results/scale_big_$n${TAG:-}.json"
bed="$work/big_bed_$n.h5"; grey="$work/big_grey_$n.nrrd"
d="$(echo "$n/16*0.05" | bc -l)"
c="$(echo "0.5*($n-1)*0.1" | bc -l)"; r="$(echo "0.47*$n*0.1" | bc -l)"
commit="$(git -C "$root" rev-parse --short HEAD)"
{
  echo "{\"commit\":\"$commit\",\"n\":$n,\"threads\":2,\"stats_limit\":\"$stats_limit\",\"ingest_limit\":\"$ingest_limit\",\"runs\":["
  run generate_bed "$n" "$make" "$bed" "$n" 32 1
  if [[ "$stages" == *" stats "* ]]; then
  echo ","
  run stats_streamed "$n" "$voxpack" --quiet --threads 2 --memory-limit "$stats_limit" stats "$bed" \
    --only axial,radial,s2 --s2-max-lag-mm 3.2 --particle-diameter-mm "$d" -o "$work/big_stats_$n.json"
  fi
  if [[ "$stages" == *" ingest "* ]]; then
  echo ","
  run generate_grey "$n" /usr/bin/python3 "$root/bench/scale/make_grey_nrrd.py" "$n" "$grey" 1; echo ","
  run ingest_streamed "$n" "$voxpack" --quiet --threads 2 --memory-limit "$ingest_limit" ingest "$grey" \
    --threshold otsu --column "$c,$c,$r" -o "$work/big_ingested_$n.h5" --json
  fi
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
# What the stats run chose (slabs, tiles, FFT box, estimate) and its porosity; the MPI runs
# against the one-process run (or, with STAGES=none, against the 1-rank run).
/usr/bin/python3 - "$work" "$out" <<'PY'
import json, os, sys
work, path = sys.argv[1], sys.argv[2]
o = json.load(open(path)); n = o["n"]
ref = os.path.join(work, "big_stats_%d.json" % n)
if not os.path.exists(ref) or "stats_streamed" not in [r["run"] for r in o["runs"]]:
    ref = os.path.join(work, "big_mpi1_%d.json" % n)
o["reference"] = os.path.basename(ref)
s = json.load(open(ref)) if os.path.exists(ref) else None
if s:
    o["stats_streamed"] = s.get("streamed"); o["stats_fft_dims"] = s["s2"]["fft_dims"]
    o["stats_memory_estimate"] = s.get("memory_estimate_bytes"); o["porosity"] = s.get("porosity")
for r in o["runs"]:
    if r["run"].startswith("stats_mpi_np") and s:
        f = os.path.join(work, "big_mpi%s_%d.json" % (r["run"][12:], n))
        if os.path.exists(f):
            m = json.load(open(f))
            r["porosity"] = m.get("porosity")
            r["streamed"] = m.get("streamed")
            r["s2_pairs_equal_to_reference"] = m["s2"].get("pairs") == s["s2"].get("pairs")
            r["s2_equal_to_reference"] = m["s2"].get("s2") == s["s2"].get("s2")
            r["axial_equal_to_reference"] = m.get("axial") == s.get("axial")
            r["radial_equal_to_reference"] = m.get("radial") == s.get("radial")
for r in o["runs"]:
    r["cpu_us_per_voxel"] = (r["user_s"] + r["sys_s"]) * 1e6 / r["voxels"]
json.dump(o, open(path, "w"), indent=1)
PY
[ "${KEEP:-0}" = 1 ] || rm -f "$bed" "$grey" "$work/big_ingested_$n.h5"
echo "wrote $out" >&2
