#!/bin/sh
# Poured DEM sphere bed (60 spheres d 3 mm, cylinder D 15 mm, h 20 mm, seed 1) at several
# voxel sizes through `voxpack flow`; the FLOW.json files go to OUTDIR and a summary
# (k against Kozeny-Carman, Ergun and Eisfeld-Schnitzlein in the Stokes limit, wall share)
# to OUTDIR/flow_dem.json. Usage: dem_bed.sh VOXPACK OUTDIR [VOXEL_MM ...]
# The 60 spheres fill the lower ~8 mm of the 20 mm container: only z = 1..7 mm (ROI, away
# from the floor and the loose top) is the bed; the empty headspace in series would
# inflate k by the length ratio.
set -e
VOXPACK=$1; OUT=$2; shift 2
mkdir -p "$OUT"
for h in ${*:-0.5 0.3 0.2}; do
  [ -f "$OUT/dem_$h.h5" ] || "$VOXPACK" pack --mode dem --shape sphere:d=3 \
      --container cylinder:d=15,h=20 --voxel-size "$h" --count 60 --seed 1 \
      -o "$OUT/dem_$h.h5" --quiet --threads 2
  /usr/bin/time -f "%e s wall %M KB" "$VOXPACK" flow "$OUT/dem_$h.h5" -o "$OUT/flow_dem_$h.json" \
      --roi-mm "${ROI:-1:7}" --quiet --threads 2 2> "$OUT/time_$h.txt"
  echo "voxel $h: $(cat "$OUT/time_$h.txt") load $(cut -d' ' -f1-3 /proc/loadavg)" >> "$OUT/log.txt"
done
/usr/bin/python3 - "$OUT" <<'PY'
import glob, json, os, sys
out = sys.argv[1]; rows = []
for f in sorted(glob.glob(os.path.join(out, "flow_dem_*.json"))):
    j = json.load(open(f)); pk = j["permeability_correlations"]; k = j["permeability_mm2"]
    rows.append({"voxel_mm": j["voxel_mm"], "voxels_per_d": j["particle_diameter_mm"] / j["voxel_mm"],
                 "status": j["status"], "steps": j["steps"], "porosity": j["porosity"],
                 "permeability_mm2": k, "kozeny_carman_mm2": pk["kozeny_carman_mm2"],
                 "ergun_stokes_mm2": pk["ergun_stokes_mm2"],
                 "eisfeld_schnitzlein_stokes_mm2": pk["eisfeld_schnitzlein_stokes_mm2"],
                 "k_over_kc": k / pk["kozeny_carman_mm2"],
                 "k_over_es": k / pk["eisfeld_schnitzlein_stokes_mm2"],
                 "tortuosity": j["tortuosity_hydraulic"], "wall_flow_share": j["wall_flow_share"],
                 "wall_area_share": j["wall_area_share"], "mlups": j["mlups"], "wall_s": j["wall_s"],
                 "column_diameter_mm": j["column_diameter_mm"]})
json.dump({"bed": "voxpack pack --mode dem --shape sphere:d=3 --container cylinder:d=15,h=20 "
                  "--count 60 --seed 1 --voxel-size H", "flow": "voxpack flow --roi-mm 1:7 "
                  "--threads 2 (defaults: walls+reservoirs, tau 1, float32, tolerance 1e-5)",
           "rows": rows},
          open(os.path.join(out, "flow_dem.json"), "w"), indent=1)
for r in rows: print(r)
PY
