#!/usr/bin/env bash
# The CFD benchmark of issue 16 (docs/export.md, "Into OpenFOAM"): a DEM bed of 30 spheres
# (d 3 mm) in a 10 mm tube, exported with bridge contacts, meshed by snappyHexMesh,
# checked by checkMesh, solved by simpleFoam at creeping flow, and compared with
# `voxpack flow` on the same bed. Not CI. Needs OpenFOAM v1912 (bench/cfd/install_openfoam.sh).
#
#   bench/cfd/run_cfd.sh VOXPACK WORKDIR OUT_JSON [LEVEL]
#
# LEVEL: snappyHexMesh surface refinement on the 0.5 mm background (1: 0.25 mm cells at
# the surfaces, 0.125 mm at bridges and other features; 2: halves both). Each heavy step
# runs serially under `timeout`; `uptime` is logged next to each timing (shared machine).
set -euo pipefail
VOXPACK=$(realpath "$1"); WORK=$2; OUT=$(realpath -m "$3"); LEVEL=${4:-1}
HERE=$(cd "$(dirname "$0")" && pwd)
export FOAM_ETC=/usr/share/openfoam/etc WM_PROJECT_DIR=/usr/share/openfoam
command -v snappyHexMesh >/dev/null || { echo "OpenFOAM missing: run $HERE/install_openfoam.sh"; exit 1; }
mkdir -p "$WORK"; cd "$WORK"
T=$PWD/timings.txt; : > $T
step() {  # step NAME CAP_S CMD...: run with a wall cap, log wall time, peak RSS and load
  local name=$1 cap=$2; shift 2
  echo "$name: start $(uptime)" >> $T
  /usr/bin/time -f "$name: %e s wall, %M KB peak" -a -o $T timeout "$cap" "$@"
  echo "$name: end $(uptime)" >> $T
}
R=5; H=16; NU=1000
[ -f bed30.h5 ] || step pack 300 "$VOXPACK" pack --mode dem --shape sphere:d=3 \
  --container cylinder:d=10,h=16 --voxel-size 0.15 --count 30 --seed 1 -o bed30.h5 --quiet
[ -f flow30.json ] || step voxpack_flow 1500 "$VOXPACK" flow bed30.h5 -o flow30.json --threads 2 --quiet
step export 300 "$VOXPACK" export bed30.h5 --format stl --contacts bridge --wall-contacts side \
  --no-wall -o bed30_bridge.stl --json --threads 2 --quiet > export30.json
CASE=case_level$LEVEL
rm -rf "$CASE"
/usr/bin/python3 "$HERE/make_case.py" "$CASE" bed30_bridge.stl --radius-mm $R --bed-height-mm $H \
  --level "$LEVEL" --nu-mm2-s $NU --iterations 300
cd "$CASE"
blockMesh > log.blockMesh 2>&1
step snappyHexMesh 2400 snappyHexMesh -overwrite > log.snappyHexMesh 2>&1
checkMesh > log.checkMesh 2>&1 || true
grep -q "Mesh OK." log.checkMesh || { echo "checkMesh failed: $CASE/log.checkMesh"; exit 1; }
step simpleFoam 1800 simpleFoam > log.simpleFoam 2>&1
cd ..
/usr/bin/python3 "$HERE/summarize.py" "$CASE" flow30.json export30.json "$OUT" --radius-mm $R \
  --bed-height-mm $H --nu-mm2-s $NU --timings timings.txt --level "$LEVEL"
