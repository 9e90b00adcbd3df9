#!/bin/sh
# k against the reservoir thickness (docs/flow.md, "Reservoir thickness"): the poured DEM sphere
# bed of dem_bed.sh (60 spheres d 3 mm, D/d 5, seed 1) at each voxel size, walls + reservoirs,
# --roi-mm 1:7, halfway and interpolated walls, at each --reservoir-layers value (0 = the
# automatic 0.6 d). FLOW.json files and OUTDIR/flow_reservoir_layers.json go to OUTDIR.
# Usage: reservoir_layers.sh VOXPACK OUTDIR ["VOXEL:LAYERS,LAYERS ..."] [THREADS (2)]
set -e
VOXPACK=$1; OUT=$2
CASES=${3:-"0.3:4,6,13,20,0 0.1:4,12,18,40,0"}
TH=${4:-2}
mkdir -p "$OUT"
for c in $CASES; do
  h=${c%%:*}
  [ -f "$OUT/bed_$h.h5" ] || "$VOXPACK" pack --mode dem --shape sphere:d=3 \
      --container cylinder:d=15,h=20 --voxel-size "$h" --count 60 --seed 1 \
      -o "$OUT/bed_$h.h5" --quiet --threads "$TH"
  for L in $(echo "${c#*:}" | tr ',' ' '); do
    for w in halfway interpolated; do
      l0=$(cut -d' ' -f1-3 /proc/loadavg)
      /usr/bin/time -f "%e %U" -o "$OUT/time_${h}_${L}_$w.txt" "$VOXPACK" --threads "$TH" flow \
          "$OUT/bed_$h.h5" -o "$OUT/flow_${h}_${L}_$w.json" --roi-mm 1:7 --walls "$w" \
          --reservoir-layers "$L" --quiet
      echo "$l0 | $(cut -d' ' -f1-3 /proc/loadavg)" > "$OUT/load_${h}_${L}_$w.txt"
    done
  done
done
PYTHONPATH="$(dirname "$0")" /usr/bin/python3 - "$OUT" "$TH" $CASES <<'PY'
import json, os, sys
from run_record import DEM_BED, run_record
out, th, cases = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
rows = []
for c in cases:
    h, layers = c.split(":")
    for L in layers.split(","):
        for w in ("halfway", "interpolated"):
            j = json.load(open(os.path.join(out, f"flow_{h}_{L}_{w}.json")))
            rows.append({"voxel_mm": float(h), "voxels_per_d": 3 / float(h),
                         "layers_asked": int(L), "layers": j["reservoir_layers"],
                         "reservoir_d": j["reservoir_layers"] * float(h) / 3, "walls": w,
                         "status": j["status"], "steps": j["steps"],
                         "permeability_mm2": j["permeability_mm2"], "fluid_cells": j["fluid_cells"],
                         **run_record(out, f"{h}_{L}_{w}")})
json.dump({"bed": DEM_BED + " --voxel-size H",
           "flow": f"voxpack --threads {th} flow --roi-mm 1:7 --walls W --reservoir-layers L "
                   "(0 = automatic; walls+reservoirs, tau 1, float32, tolerance 1e-5)",
           "rows": rows}, open(os.path.join(out, "flow_reservoir_layers.json"), "w"), indent=1)
for r in rows:
    print(f"{r['voxel_mm']} mm L{r['layers']} ({r['reservoir_d']:.2f} d) {r['walls']}: "
          f"k {r['permeability_mm2']:.6f}, {r['steps']} steps")
PY
