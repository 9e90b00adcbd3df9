#!/bin/sh
# Interpolated walls with and without the mass correction (docs/flow.md, "Mass") on the poured
# DEM sphere bed of dem_bed.sh at 0.3 mm (60 spheres d 3 mm, D/d 5, seed 1), walls +
# reservoirs, tau 1, float32, at the default tolerance 1e-5 and at 1e-7, --max-steps MAX.
# FLOW.json files and a summary (OUTDIR/flow_mass_correction.json) go to OUTDIR.
# RESERVOIR_LAYERS (environment, default 0 = the automatic 0.6 d) sets --reservoir-layers; the
# committed bench/results/flow_mass_correction_2026-12-07.json ran before that default, at 4.
# Usage: mass_correction.sh VOXPACK OUTDIR [MAX_STEPS (100000)] [THREADS (1)]
set -e
VOXPACK=$1; OUT=$2; MAX=${3:-100000}; TH=${4:-1}; LAYERS=${RESERVOIR_LAYERS:-0}
mkdir -p "$OUT"
[ -f "$OUT/bed.h5" ] || "$VOXPACK" pack --mode dem --shape sphere:d=3 \
    --container cylinder:d=15,h=20 --voxel-size 0.3 --count 60 --seed 1 \
    -o "$OUT/bed.h5" --quiet --threads "$TH"
for tol in 1e-5 1e-7; do
  for mc in on off; do
    extra=""
    [ "$mc" = off ] && extra="--no-mass-correction"
    l0=$(cut -d' ' -f1-3 /proc/loadavg)
    /usr/bin/time -f "%e %U" -o "$OUT/time_${tol}_$mc.txt" "$VOXPACK" flow "$OUT/bed.h5" \
        -o "$OUT/flow_${tol}_$mc.json" --roi-mm 1:7 --walls interpolated --tolerance "$tol" \
        --max-steps "$MAX" --threads "$TH" --reservoir-layers "$LAYERS" --quiet $extra
    echo "$l0 | $(cut -d' ' -f1-3 /proc/loadavg)" > "$OUT/load_${tol}_$mc.txt"
  done
done
PYTHONPATH="$(dirname "$0")" /usr/bin/python3 - "$OUT" "$MAX" "$TH" <<'PY'
import json, os, sys
from run_record import DEM_BED, run_record
out, mx, th = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rows = []
for tol in ("1e-5", "1e-7"):
    for mc in ("on", "off"):
        j = json.load(open(os.path.join(out, f"flow_{tol}_{mc}.json")))
        rows.append({"tolerance": float(tol), "mass_correction": mc == "on",
                     "status": j["status"], "steps": j["steps"], "residual": j["residual"],
                     "permeability_mm2": j["permeability_mm2"],
                     "mass_relative_change": j["mass_relative_change"],
                     "mass_correction_relative": j["mass_correction_relative"],
                     "interpolated_links": j["interpolated_links"], "fluid_cells": j["fluid_cells"],
                     **run_record(out, f"{tol}_{mc}")})
json.dump({"bed": DEM_BED + " --voxel-size 0.3",
           "flow": f"voxpack flow --roi-mm 1:7 --walls interpolated --tolerance T --max-steps {mx} "
                   f"--threads {th} [--no-mass-correction] (walls+reservoirs, tau 1, float32)",
           "rows": rows}, open(os.path.join(out, "flow_mass_correction.json"), "w"), indent=1)
for r in rows: print(r)
PY
