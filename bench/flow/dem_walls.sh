#!/usr/bin/env bash
# Halfway against interpolated walls on the poured 60-sphere DEM bed at 0.3-0.1 mm
# (docs/flow.md, "Halfway against interpolated walls on the poured DEM sphere bed").
#   bench/flow/dem_walls.sh BUILD_DIR OUT.json [VOXEL_SIZES]
set -euo pipefail
build=${1:?build dir}
out=${2:?output json}
sizes=${3:-0.3 0.2 0.15 0.1}
vox="$build/bin/voxpack"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for h in $sizes; do
  "$vox" pack --mode dem --shape sphere:d=3 --container cylinder:d=15,h=20 --count 60 --seed 1 \
    --voxel-size "$h" -o "$tmp/bed_$h.h5" >/dev/null 2>&1
  for w in halfway interpolated; do
    "$vox" --threads 2 flow "$tmp/bed_$h.h5" -o "$tmp/f_${h}_$w.json" --roi-mm 1:7 --walls "$w" \
      >/dev/null 2>&1
  done
done
/usr/bin/python3 - "$tmp" "$out" $sizes <<'PY'
import json, sys
tmp, out, sizes = sys.argv[1], sys.argv[2], sys.argv[3:]
keep = ["permeability_mm2", "porosity", "steps", "status", "interpolated_links",
        "mass_relative_change", "tortuosity_hydraulic", "wall_s", "solver_wall_s", "mlups"]
rows = []
for h in sizes:
    row = {"voxel_mm": float(h), "voxels_per_d": 3 / float(h)}
    for w in ("halfway", "interpolated"):
        j = json.load(open(f"{tmp}/f_{h}_{w}.json"))
        row[w] = {k: j.get(k) for k in keep}
        if w == "interpolated":
            row[w]["distance_s"] = j["wall_geometry"]["distance_s"]
    row["ratio"] = row["interpolated"]["permeability_mm2"] / row["halfway"]["permeability_mm2"]
    print(f"{h} mm: k halfway {row['halfway']['permeability_mm2']:.5f}, interpolated "
          f"{row['interpolated']['permeability_mm2']:.5f}, ratio {row['ratio']:.3f}")
    rows.append(row)
json.dump({"what": "60 DEM spheres d 3 in cylinder:d=15,h=20, seed 1, flow --roi-mm 1:7, 2 threads",
           "command": "bench/flow/dem_walls.sh " + " ".join(sys.argv[2:]), "rows": rows},
          open(out, "w"), indent=1)
PY
