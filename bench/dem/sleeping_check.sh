#!/usr/bin/env bash
# Does sleeping leave a bed looser than it would be? (docs/dem.md "Sleeping on and off")
#   bench/dem/sleeping_check.sh BUILD_DIR OUT_DIR [SEED] [BED.h5] [SIM_S]
# Without BED, pours the paper's bed as the LIGGGHTS comparison does (samples/paper_dem.toml,
# one cloud, the peer's energy rule, sleeping on). Then continues that same bed (--from) for
# SIM_S (default 0.3) simulated seconds twice, with sleeping on and with sleeping off (every
# particle integrated throughout; the energy threshold 1e-12 so only the cap or a bed wholly
# asleep ends a run), and compares their densities (dem_bed_density: the window 2 d above
# the floor to 2 d below the top, and the core r < R - 2 d). Frozen particles that held load
# off the layers below would show as compaction once everything is awake.
# Raw JSON to OUT_DIR/dem_sleeping_check.json.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
build=${1:?build dir}
out=${2:?output dir}
seed=${3:-1}
bed=${4:-}
sim=${5:-0.3}
vox="$build/bin/voxpack"
mkdir -p "$out"
if [[ -z $bed ]]; then
  bed="$out/poured.h5"
  "$vox" --threads 1 pack --config "$root/samples/paper_dem.toml" --rain-height 0 \
    --rain-fraction 0.15 --settle-speed 0 --seed "$seed" -o "$bed" >"$out/poured.out" 2>"$out/poured.err"
fi
"$build/bin/dem_bed_density" "$bed" 5.4 >"$out/start.density.json"
# The [dem] values of samples/paper_dem.toml as flags: the scene file also sets a fill height,
# which with --from would pour more on top.
for s in on off; do
  /usr/bin/time -f "%e %U" -o "$out/$s.time" "$vox" --threads 1 pack --mode dem --from "$bed" \
    --friction 0.1 --restitution 0.5 --density 1.5 --sleeping "$s" --settle-kinetic 1e-12 \
    --settle-speed 0 --max-time "$sim" --seed "$seed" -o "$out/$s.h5" >"$out/$s.out" 2>"$out/$s.err"
  "$vox" info --json "$out/$s.h5" >"$out/$s.info.json"
  "$build/bin/dem_bed_density" "$out/$s.h5" 5.4 >"$out/$s.density.json"
done
/usr/bin/python3 - "$out" "$bed" "$seed" "$sim" <<'PY'
import json, sys
out, bed, seed, sim = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4])
def dens(n):
    d = json.load(open(f"{out}/{n}.density.json"))
    return {"window": d["density_cross_section"], "core": d["core_density"], "top_mm": d["bed_top_mm"]}
res = {"what": "paper bed continued with sleeping on and off (bench/dem/sleeping_check.sh)",
       "bed": bed, "seed": seed, "simulated_s": sim, "start": dens("start"), "runs": {}}
for s in ("on", "off"):
    wall, user = open(f"{out}/{s}.time").read().split()[-2:]
    dem = json.load(open(f"{out}/{s}.info.json"))["provenance"]["dem"]
    res["runs"][s] = dict(dens(s), wall_s=float(wall), cpu_user_s=float(user),
                          simulated_time_s=dem["simulated_time_s"],
                          integrated_share=dem["integrated_particle_steps"] / max(1, dem["particle_steps"]))
on, off = res["runs"]["on"], res["runs"]["off"]
res["window_off_minus_on"] = off["window"] - on["window"]
res["core_off_minus_on"] = off["core"] - on["core"]
print(f"start {res['start']['window']:.5f}; sleeping on {on['window']:.5f} (core {on['core']:.5f}), "
      f"off {off['window']:.5f} (core {off['core']:.5f}): off - on {res['window_off_minus_on']:+.5f} "
      f"(core {res['core_off_minus_on']:+.5f})")
json.dump(res, open(f"{out}/dem_sleeping_check.json", "w"), indent=1)
PY
