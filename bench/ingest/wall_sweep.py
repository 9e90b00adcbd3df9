#!/usr/bin/python3
"""Column radius against the thickness of a thin XMT wall (docs/ingest.md, "An unresolved
wall"): the grey wall fit resolves walls of >= 2.5 voxels; thinner ones it takes at that
floor, or at half of it when that fits the profile better.

usage: wall_sweep.py VOXPACK WORKDIR OUT.json [--seeds 3,4,5] [--vpd 10]

The fidelity benchmark's sphere bed (d 3 mm, 15 mm column, MC, seed 1; packed into WORKDIR
unless there) is imaged by `voxpack phantom --modality xmt --snr 10`, blur 1 voxel, at VPD
voxels per d, with walls of 1 to 4 image voxels (`--wall-mm`). Each image is ingested three
ways: the default (fitted), `--column-wall-mm` at 2.5 voxels (the floor: the fit before
2026-12-07 on every wall it could not resolve) and `--column-wall-mm` at the true thickness
(known). Recorded: the radius error in voxels against the truth's area-equivalent radius,
the thickness the fit used and whether it flagged the wall as unresolved.
"""
import json
import os
import subprocess
import sys
import time

import h5py
import numpy as np

VOX, WORK, OUT = os.path.abspath(sys.argv[1]), sys.argv[2], sys.argv[3]
ARGS = sys.argv[4:]
SEEDS = [int(s) for s in (ARGS[ARGS.index("--seeds") + 1].split(",") if "--seeds" in ARGS
                          else ["3"])]
VPD = float(ARGS[ARGS.index("--vpd") + 1]) if "--vpd" in ARGS else 10.0
WALLS_VOX = [1.0, 1.33, 1.5, 2.0, 2.5, 3.0, 4.0]
D = 3.0
os.makedirs(WORK, exist_ok=True)


def run(args):
    r = subprocess.run([VOX] + args, capture_output=True, text=True, timeout=600)
    if r.returncode != 0:
        raise RuntimeError(" ".join(args) + "\n" + r.stderr)
    return r


truth = os.path.join(WORK, "spheres_truth.h5")
if not os.path.exists(truth):
    run(["-q", "--threads", "2", "pack", "--mode", "mc", "--shape", "sphere:d=3", "--container",
         "cylinder:d=15,h=26", "--voxel-size", "0.1", "--fill-height", "24", "--seed", "1", "-o",
         truth])
with h5py.File(truth, "r") as f:
    mask = f["mask"][...]
    sp = np.array(f.attrs["spacing_mm"], dtype=float)
radius = float(np.sqrt(mask[mask.shape[0] // 2].sum() / np.pi) * sp[2])
voxel = D / VPD
t0 = time.time()
records = []
for seed in SEEDS:
    for w in WALLS_VOX:
        img = os.path.join(WORK, "wall.nrrd")
        run(["-q", "--threads", "2", "phantom", truth, "--modality", "xmt", "--snr", "10",
             "--blur-mm", f"{voxel:.6f}", "--voxel-size", f"{voxel:.6f}", "--wall-mm",
             f"{w * voxel:.6f}", "--seed", str(seed), "-o", img])
        for how, flags in (("fitted", []), ("floor", ["--column-wall-mm", f"{2.5 * voxel:.6f}"]),
                           ("known", ["--column-wall-mm", f"{w * voxel:.6f}"])):
            seg = os.path.join(WORK, "wall.h5")
            rep = json.loads(run(["--threads", "2", "ingest", img, "-o", seg, "--json"] +
                                 flags).stdout)
            c = rep["column"]
            rec = dict(seed=seed, wall_voxels=w, wall_mm=w * voxel, how=how,
                       refined=c.get("refined", False),
                       radius_err_voxels=(c["radius_mm"] - radius) / voxel if c["found"] else None,
                       wall_used_voxels=(c["wall_thickness_mm"] / voxel
                                         if c.get("refined") else None),
                       wall_resolved=c.get("wall_resolved"))
            print(json.dumps(rec), flush=True)
            records.append(rec)
            os.remove(seg)
        os.remove(img)
with open(OUT, "w") as f:
    json.dump(dict(description="radius error against the thickness of a thin XMT wall "
                   "(spheres d 3 mm, D 15 mm, SNR 10, blur 1 voxel)",
                   command=" ".join(["wall_sweep.py"] + sys.argv[1:]), voxels_per_d=VPD,
                   truth_radius_mm=radius, wall_s=time.time() - t0,
                   load_average=os.getloadavg(), records=records), f, indent=1)
# Summary: mean radius error per wall and way over the seeds.
for w in WALLS_VOX:
    row = []
    for how in ("fitted", "floor", "known"):
        e = [r["radius_err_voxels"] for r in records
             if r["wall_voxels"] == w and r["how"] == how and r["radius_err_voxels"] is not None]
        row.append(f"{how} {np.mean(e):+.3f}" if e else f"{how} -")
    print(f"wall {w:4.2f} voxels: " + ", ".join(row))
