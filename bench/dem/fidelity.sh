#!/usr/bin/env bash
# DEM fidelity beyond the paper (docs/dem.md "Random close packing", "Mean voidage against
# Benyahia & O'Neill"). Not run by ctest: each bed takes minutes.
#   bench/dem/fidelity.sh BUILD_DIR OUT_DIR
#                         [rcp|rcp-poured|rcp-continue|voidage|voidage-cylinders|all]
#                         [THREADS] [SEED] [FRICTIONS]
# rcp:     5000 frictionless spheres d 3 mm in a 48 mm column (D/d 16), e 0.5, 0.3 mm
#          voxels, poured, and poured + 5 taps; bulk voxel density >= 3 d from wall, floor and
#          top, g(r) from the centres (bench/dem/bed_structure.py). RCP_ARGS (environment)
#          adds pack options to both beds and RCP_TAG a suffix to their names, e.g.
#          RCP_ARGS="--target-overlap 0.001" RCP_TAG=_t0001; RCP_CONTAINER replaces the
#          container (a taller one for --rain-height 0, whose single cloud is ~130 mm).
#          RCP_RESTITUTION (default 0.5) sets e for rcp and rcp-continue (more dissipation
#          quenches the pour faster). Every bed also gets its crystal-like fraction
#          (bench/dem/crystal_order.py);
#          KEEP_BEDS=1 keeps the bed files.
# rcp-continue: continues a kept rcp bed, RCP_FROM=BED.h5 (--from: every sphere at rest at
#          its pose, no contact springs), frictionless, e 0.5, with RCP_ARGS (e.g.
#          "--target-overlap 0.0001": the rigid limit of that packing); also measures its
#          bulk three ways (bench/dem/bulk_exact.py). Not part of `all`.
# voidage: spheres d 3 mm at D/d 3, 5, 8, 12 and 20, poured at each of FRICTIONS (default
#          "0.1 0.2 0.3"), e 0.5, 0.3 mm, each bed ~10-30 d deep; mean voidage between 2 d
#          above the floor and 2 d below the top against eps = 0.390 + 1.740 / (D/d + 1.140)^2.
# voidage-cylinders: the paper's cylinders (d 5.4 x l 3.8 mm, volume-equivalent d_pe 5.498
#          mm) at D/d_pe 3, 5, 8, 12 and 20, poured at each of FRICTIONS, e 0.5, 0.54 mm voxels
#          (10 per d: VOIDCYL_VOXEL overrides), beds 20/16/12/10/8 d_pe deep (VOIDCYL_SPECS,
#          "D/d_pe:COUNT ...", runs a subset, e.g. "8:700"); against
#          eps = 0.373 + 1.703 / (D/d_pe + 0.611)^2, the voxel and the centre-count voidage.
# Raw JSON per bed in OUT_DIR/NAME.json and all of them in OUT_DIR/dem_fidelity.json.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
build=${1:?build dir}
out=${2:?output dir}
which=${3:-all}
threads=${4:-2}
seed=${5:-1}
frictions=${6:-0.1 0.2 0.3}
vox="$build/bin/voxpack"
mkdir -p "$out"

run() {  # NAME D_MM ARGS...
  local name=$1 d=$2
  shift 2
  local l0
  l0=$(cut -d' ' -f1-3 /proc/loadavg)
  /usr/bin/time -f "%e %U %M" -o "$out/$name.time" "$vox" --threads "$threads" pack --mode dem \
    --seed "$seed" "$@" -o "$out/$name.h5" >"$out/$name.out" 2>"$out/$name.err"
  echo "$l0 | $(cut -d' ' -f1-3 /proc/loadavg)" >"$out/$name.load"
  "$vox" info --json "$out/$name.h5" >"$out/$name.info.json"
  "$build/bin/dem_bed_density" "$out/$name.h5" "$d" >"$out/$name.density.json"
  /usr/bin/python3 "$here/bed_structure.py" "$out/$name.h5" "$d" >"$out/$name.structure.json"
  /usr/bin/python3 "$here/crystal_order.py" "$out/$name.h5" "$d" >"$out/$name.crystal.json"
  /usr/bin/python3 - "$out" "$name" "$*" <<'PY'
import json, sys
out, name, args = sys.argv[1:4]
b = f"{out}/{name}"
info = json.load(open(b + ".info.json"))
dem = info["provenance"]["dem"]
wall, user, rss = open(b + ".time").read().split()[-3:]
s = json.load(open(b + ".structure.json"))
res = {"name": name, "args": args, "status": info["provenance"]["status"],
       "particles": info["particles"], "wall_s": float(wall), "cpu_user_s": float(user),
       "max_rss_kb": int(rss), "load_1_5_15_before_after": open(b + ".load").read().strip(),
       "simulated_time_s": dem["simulated_time_s"], "steps": dem["steps"],
       "mean_overlap_d": dem.get("mean_overlap_d"), "max_overlap_d": dem.get("max_overlap_d"),
       "dem_bed_density": json.load(open(b + ".density.json")),
       "crystal_order": json.load(open(b + ".crystal.json")),
       "structure": {k: v for k, v in s.items() if k not in ("g", "g_r_d")},
       "g_r_d": s["g_r_d"], "g": s["g"]}
json.dump(res, open(b + ".json", "w"), indent=1)
st = res["structure"]
print(f"{name}: {res['status']}, {res['particles']} particles, {res['wall_s']:.0f} s wall, "
      f"bed phi {st['mean_phi_bed']:.4f}, bulk phi {st['bulk_phi']:.4f}, "
      f"g peak {st['g_contact_peak']:.2f} at {st['g_contact_peak_r_d']:.3f} d, "
      f"crystal-like {res['crystal_order']['bulk_crystal_fraction']:.3f}", flush=True)
PY
  [[ -n ${KEEP_BEDS:-} ]] || rm -f "$out/$name.h5"
}

if [[ $which == rcp || $which == rcp-poured || $which == all ]]; then
  # 5000 spheres of 14.14 mm^3 at ~0.62 fill ~63 mm of a 48 mm column.
  common=(--shape sphere:d=3 --container "${RCP_CONTAINER:-cylinder:d=48,h=110}"
    --voxel-size 0.3 --count 5000 --friction 0 --restitution "${RCP_RESTITUTION:-0.5}" --max-time 8)
  read -r -a extra <<<"${RCP_ARGS:-}"
  run "rcp_poured${RCP_TAG:-}" 3 "${common[@]}" "${extra[@]}"
  [[ $which == rcp-poured ]] || run "rcp_tapped${RCP_TAG:-}" 3 "${common[@]}" "${extra[@]}" --tap-cycles 5
fi
if [[ $which == rcp-continue ]]; then
  read -r -a extra <<<"${RCP_ARGS:-}"
  keep=${KEEP_BEDS:-}
  KEEP_BEDS=1 run "rcp_continued${RCP_TAG:-}" 3 --from "${RCP_FROM:?RCP_FROM=BED.h5}" \
    --friction 0 --restitution "${RCP_RESTITUTION:-0.5}" --max-time 8 "${extra[@]}"
  name="rcp_continued${RCP_TAG:-}"
  /usr/bin/python3 "$here/bulk_exact.py" "$out/$name.h5" 3 >"$out/$name.exact.json"
  /usr/bin/python3 - "$out/$name.json" "$out/$name.exact.json" <<'PY'
import json, sys
res = json.load(open(sys.argv[1]))
res["bulk_exact"] = json.load(open(sys.argv[2]))
json.dump(res, open(sys.argv[1], "w"), indent=1)
print(f"{res['name']}: bulk phi voxels {res['bulk_exact']['phi_voxels']:.4f}, exact spheres "
      f"{res['bulk_exact']['phi_union']:.4f} +- {res['bulk_exact']['phi_union_se']:.4f}")
PY
  [[ -n $keep ]] || rm -f "$out/$name.h5"
fi
# One poured bed per D/d and friction: PREFIX D_MM VOLUME_MM3 VOXEL_MM SHAPE "D/d:COUNT ...".
# The container holds the pour: its height is the settled bed (solid ~0.55) x 1.4 + 30 mm.
voidage_sweep() {
  local prefix=$1 d=$2 vol=$3 voxel=$4 shape=$5 specs=$6 mu spec r n dd h
  for mu in $frictions; do
    for spec in $specs; do
      r=${spec%%:*}
      n=${spec##*:}
      dd=$(/usr/bin/python3 -c "print(round($d * $r, 3))")
      h=$(/usr/bin/python3 -c "print(round($n * $vol / (0.55 * 3.1416 * ($r * $d) ** 2 / 4) * 1.4 + 30))")
      run "${prefix}_r${r}_mu${mu}" "$d" --shape "$shape" --container "cylinder:d=$dd,h=$h" \
        --voxel-size "$voxel" --count "$n" --friction "$mu" --restitution 0.5 --max-time 8
    done
  done
}
if [[ $which == voidage || $which == all ]]; then
  # Beds ~30/25/20/15/10 d deep; the volume 13.5 mm^3 (for 14.1) is the height rule kept
  # from the first runs.
  voidage_sweep voidage 3 13.5 0.3 sphere:d=3 "3:220 5:560 8:1150 12:1950 20:3600"
fi
if [[ $which == voidage-cylinders || $which == all ]]; then
  # Beds 20/16/12/10/8 d_pe deep (V 87.03 mm^3).
  voidage_sweep voidcyl 5.498 87.03 "${VOIDCYL_VOXEL:-0.54}" cylinder:d=5.4,l=3.8 \
    "${VOIDCYL_SPECS:-3:170 5:360 8:700 12:1300 20:2900}"
fi
/usr/bin/python3 - "$out" <<'PY'
import glob, json, sys
out = sys.argv[1]
rows = [json.load(open(p)) for p in sorted(glob.glob(f"{out}/*.json"))
        if not p.endswith((".info.json", ".density.json", ".structure.json", ".crystal.json",
                              ".exact.json", "dem_fidelity.json"))]
for r in rows:
    if r["name"].startswith("voidage"):
        nominal = float(r["name"].split("_r")[1].split("_")[0])
        r["benyahia_voidage"] = 0.390 + 1.740 / (nominal + 1.140) ** 2
        r["voidage_minus_benyahia"] = r["structure"]["mean_voidage_bed"] - r["benyahia_voidage"]
    if r["name"].startswith("voidcyl"):
        nominal = float(r["name"].split("_r")[1].split("_")[0])
        r["benyahia_voidage"] = 0.373 + 1.703 / (nominal + 0.611) ** 2
        r["voidage_minus_benyahia"] = r["structure"]["mean_voidage_bed"] - r["benyahia_voidage"]
json.dump({"what": "DEM fidelity: random close packing and mean voidage (bench/dem/fidelity.sh)",
           "beds": rows}, open(f"{out}/dem_fidelity.json", "w"), indent=1)
for r in rows:
    if "benyahia_voidage" in r:
        print(f"{r['name']}: voidage {r['structure']['mean_voidage_bed']:.4f} (centres "
              f"{r['structure']['mean_voidage_bed_centres']:.4f}), Benyahia "
              f"{r['benyahia_voidage']:.4f}, difference {r['voidage_minus_benyahia']:+.4f}")
PY
