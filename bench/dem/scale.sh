#!/usr/bin/env bash
# The multi-tube reactor scale case of issue 18 (docs/dem.md "Scale"): cylinders d 2 mm,
# l 2 mm (d_pe 2.29 mm) poured into a tube of D 11.5 mm (D/d_pe 5), 0.2 mm voxels (10 per d),
# default rain, 2 threads. COUNTS particles each (default "1000 10000"; the tube is made
# long enough for each: 10^4 fill ~1.1 m). MAX_TIME_S caps the simulated time (default 20).
#   bench/dem/scale.sh BUILD_DIR OUT_DIR ["COUNTS"] [MAX_TIME_S] [THREADS]
# Per run (scale_summary.py): wall and CPU (/usr/bin/time), max RSS, status, simulated time,
# time step and the depth that set the stiffness, overlaps, neighbour rebuilds, particle-steps
# and the wall seconds per particle-step (all, and integrated ones), so the cost can be
# compared from 10^3 to 10^4 particles even when the cap stops a run. Raw JSON to
# OUT_DIR/dem_scale.json.
set -euo pipefail
build=${1:?build dir}
out=${2:?output dir}
counts=${3:-1000 10000}
maxt=${4:-20}
threads=${5:-2}
vox="$build/bin/voxpack"
mkdir -p "$out"
for n in $counts; do
  # ~0.55 solid fraction of a 11.5 mm tube: 6.28 mm^3 a cylinder -> 0.11 mm of tube each.
  h=$(/usr/bin/python3 -c "print(int($n * 6.2832 / (0.55 * 3.14159 * 5.75 ** 2) * 1.15 + 20))")
  cut -d' ' -f1-3 /proc/loadavg >"$out/n$n.load"
  /usr/bin/time -f "%e %U %M" -o "$out/n$n.time" "$vox" --threads "$threads" pack --mode dem \
    --shape cylinder:d=2,l=2 --container "cylinder:d=11.5,h=$h" --voxel-size 0.2 --count "$n" \
    --friction 0.3 --restitution 0.5 --seed 1 --max-time "$maxt" -o "$out/n$n.h5" \
    >"$out/n$n.out" 2>"$out/n$n.err" || true
  cut -d' ' -f1-3 /proc/loadavg >>"$out/n$n.load"
  "$vox" info --json "$out/n$n.h5" >"$out/n$n.info.json"
  rm -f "$out/n$n.h5"
done
/usr/bin/python3 "$(dirname "$0")/scale_summary.py" "$out" "$counts" "$maxt" "$threads"
