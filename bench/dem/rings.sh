#!/usr/bin/env bash
# Holed and concave pellets of issue 18 (docs/dem.md "Rings and trilobes"): Raschig-proportioned
# rings (d 6, di 4.8, l 6 mm: wall d/10 as a ceramic 50 x 50 x 5 mm ring) in a D 48 mm column
# (D/d 8) at 0.2 mm voxels (3 across the wall; contact nodes at 0.3 mm), and trilobes (d 3,
# lobes 1.8, l 4.5 mm) in a D 24 mm column at 0.15 mm. Friction 0.3, restitution 0.5, rolling
# resistance 0.05 (a ring on its side rolls on a flat floor otherwise), seed 1, THREADS
# threads. Each bed goes through ring_check.py (every particle digitised from its exact pose:
# the voxels it shares, its bore, the mean voidage); OUT_DIR/dem_rings.json holds those, the
# provenance's interpenetration counters, wall and CPU time and max RSS.
#   bench/dem/rings.sh BUILD_DIR OUT_DIR [RINGS] [TRILOBES] [THREADS]
set -euo pipefail
build=${1:?build dir}
out=${2:?output dir}
rings=${3:-200}
trilobes=${4:-300}
threads=${5:-1}
vox="$build/bin/voxpack"
here="$(cd "$(dirname "$0")" && pwd)"
mkdir -p "$out"
run() {  # name spec container voxel contact-voxel count
  local name=$1 spec=$2 container=$3 voxel=$4 cvox=$5 n=$6
  cut -d' ' -f1-3 /proc/loadavg >"$out/$name.load"
  /usr/bin/time -f "%e %U %M" -o "$out/$name.time" "$vox" --threads "$threads" pack --mode dem \
    --shape "$spec" --container "$container" --voxel-size "$voxel" --contact-voxel "$cvox" \
    --count "$n" --friction 0.3 --restitution 0.5 --rolling-friction 0.05 --seed 1 \
    --max-time 10 -o "$out/$name.h5" >"$out/$name.out" 2>"$out/$name.err" || true
  cut -d' ' -f1-3 /proc/loadavg >>"$out/$name.load"
  /usr/bin/python3 "$here/ring_check.py" "$out/$name.h5" "$spec" >"$out/$name.check.json"
  "$vox" info --json "$out/$name.h5" >"$out/$name.info.json"
  rm -f "$out/$name.h5"
}
run rings ring:d=6,di=4.8,l=6 cylinder:d=48,h=150 0.2 0.3 "$rings"
run trilobes trilobe:d=3,l=4.5 cylinder:d=24,h=100 0.15 0.15 "$trilobes"
/usr/bin/python3 "$here/rings_summary.py" "$out" "$threads"
