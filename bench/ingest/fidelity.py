#!/usr/bin/python3
"""Ingest fidelity: density bias and near-wall profile error of `voxpack ingest` on phantoms
of known beds, before (Otsu, voxel-level column) and after (the default pipeline).

usage: fidelity.py VOXPACK WORKDIR OUT.json [--quick] [--diagnose-only] [--sweep-only]

Beds (packed once into WORKDIR by `voxpack pack --mode mc`, fine lattice = the truth):
  spheres   d 3 mm in a 24 mm column (8 d), 15 mm of bed, at 0.1 mm (30 voxels per d)
  cylinders the paper's pellets d 5.4 x l 3.8 mm in the 43.3 mm column, 12 mm of bed,
            at 0.18 mm (30 voxels per d)
Each image: `voxpack phantom --voxel-size d/vpd --snr S --blur-mm b*voxel --modality M`,
then `voxpack ingest` (after: defaults; before: --threshold otsu --no-refine-column
--noise gaussian), then `voxpack stats --only radial --roi-mm Z0:Z1` on truth and
ingested bed over the packed region (slices with >= half the peak solid share, one d in
from each end). Bias = ingested - truth packing density; near-wall RMSE = RMSE of the
radial density over the first d from the wall (bins 0.1 d, matched by wall distance).
"""
import json
import os
import subprocess
import sys
import time

import h5py
import numpy as np

VOX = sys.argv[1]
WORK = sys.argv[2]
OUT = sys.argv[3]
QUICK = "--quick" in sys.argv
os.makedirs(WORK, exist_ok=True)

BEDS = {
    "spheres": dict(d=3.0, shape="sphere:d=3", container="cylinder:d=24,h=20", fill=15.0,
                    voxel=0.1),
    "cylinders": dict(d=5.4, shape="cylinder:d=5.4,l=3.8", container="cylinder:d=43.3,h=18",
                      fill=12.0, voxel=0.18),
}


def run(args, **kw):
    t0 = time.time()
    r = subprocess.run([VOX] + args, capture_output=True, text=True, **kw)
    if r.returncode != 0:
        raise RuntimeError(" ".join(args) + "\n" + r.stderr)
    return r, time.time() - t0


def truth_bed(name):
    b = BEDS[name]
    path = os.path.join(WORK, f"{name}_truth.h5")
    if not os.path.exists(path):
        _, s = run(["-q", "--threads", "2", "pack", "--mode", "mc", "--shape", b["shape"],
                    "--container", b["container"], "--voxel-size", str(b["voxel"]),
                    "--fill-height", str(b["fill"]), "--seed", "1", "-o", path])
        print(f"packed {name} in {s:.0f} s", flush=True)
    return path


def packed_roi(path, d):
    with h5py.File(path, "r") as f:
        ind = f["indicator"][...]
        mask = f["mask"][...]
        sz = f.attrs["spacing_mm"][0]
        oz = f.attrs["origin_mm"][0]
    inm = mask.sum(axis=(1, 2)).astype(float)
    sol = ((ind == 0) & (mask == 1)).sum(axis=(1, 2)) / np.maximum(inm, 1)
    ks = np.nonzero(sol >= 0.5 * sol.max())[0]
    z0 = oz + ks[0] * sz + d
    z1 = oz + ks[-1] * sz - d
    return z0, z1


def stats(path, roi, d):
    out = path.replace(".h5", "_stats.json")
    run(["-q", "stats", path, "-o", out, "--only", "radial", "--roi-mm",
         f"{roi[0]:.4f}:{roi[1]:.4f}", "--radial-bin-mm", f"{0.1 * d:.4f}"])
    with open(out) as f:
        j = json.load(f)
    r = j["radial"]
    return dict(density=j["packing_density"], r=np.array(r["r_mm"]),
                rho=np.array([np.nan if v is None else v for v in r["density"]]),
                radius=r["radius_mm"])


def near_wall_rmse(t, s, d):
    wt = t["radius"] - t["r"]
    ws = s["radius"] - s["r"]
    sel = (wt >= 0) & (wt <= d) & np.isfinite(t["rho"])
    ok = np.isfinite(s["rho"])
    order = np.argsort(ws[ok])
    si = np.interp(wt[sel], ws[ok][order], s["rho"][ok][order])
    return float(np.sqrt(np.mean((si - t["rho"][sel]) ** 2)))


TRUTH = {}


def truth(name):
    if name not in TRUTH:
        p = truth_bed(name)
        d = BEDS[name]["d"]
        roi = packed_roi(p, d)
        TRUTH[name] = dict(path=p, roi=roi, stats=stats(p, roi, d))
    return TRUTH[name]


def case(name, vpd, snr, blur_vox, modality="mri", variants=("after", "before"), seed=3):
    b = BEDS[name]
    t = truth(name)
    voxel = b["d"] / vpd
    tag = f"{name}_{modality}_v{vpd}_s{snr}_b{blur_vox}"
    img = os.path.join(WORK, tag + ".nrrd")
    run(["-q", "--threads", "2", "phantom", t["path"], "--modality", modality, "--snr", str(snr),
         "--blur-mm", f"{blur_vox * voxel:.6f}", "--voxel-size", f"{voxel:.6f}", "--seed",
         str(seed), "-o", img])
    recs = []
    for v in variants:
        extra = VARIANTS[v]
        seg = os.path.join(WORK, f"{tag}_{v}.h5")
        r, secs = run(["--threads", "2", "ingest", img, "-o", seg, "--json"] + extra(t, b))
        rep = json.loads(r.stdout)
        s = stats(seg, t["roi"], b["d"])
        rec = dict(bed=name, modality=modality, voxels_per_d=vpd, snr=snr, blur_voxels=blur_vox,
                   voxel_mm=voxel, variant=v, truth_density=t["stats"]["density"],
                   density=s["density"], bias=s["density"] - t["stats"]["density"],
                   near_wall_rmse=near_wall_rmse(t["stats"], s, b["d"]),
                   radius_err_voxels=(rep["column"].get("radius_mm", float("nan")) -
                                      t["stats"]["radius"]) / voxel,
                   column_found=rep["column"]["found"], threshold=rep["threshold"]["method"],
                   quality=rep.get("quality"), ingest_wall_s=secs,
                   warning="no column" if not rep["column"]["found"] else "")
        print(json.dumps({k: rec[k] for k in ("bed", "modality", "voxels_per_d", "snr",
                                                "blur_voxels", "variant", "bias",
                                                "near_wall_rmse", "radius_err_voxels")}),
              flush=True)
        recs.append(rec)
        os.remove(seg)
    os.remove(img)
    return recs


def true_column(t, b):
    with h5py.File(t["path"], "r") as f:
        m = f["mask"][f["mask"].shape[0] // 2]
        sp = f.attrs["spacing_mm"]
        org = f.attrs["origin_mm"]
    j, i = np.nonzero(m)
    return ["--column", f"{org[2] + i.mean() * sp[2]:.5f},{org[1] + j.mean() * sp[1]:.5f},"
            f"{np.sqrt(m.sum() / np.pi) * sp[2]:.5f}"]


BEFORE = ["--threshold", "otsu", "--no-refine-column", "--noise", "gaussian"]
VARIANTS = {
    "after": lambda t, b: [],
    "before": lambda t, b: BEFORE,
    # Diagnosis steps, each on top of "before" unless named otherwise.
    "before+refined_column": lambda t, b: ["--threshold", "otsu"],
    "before+true_column": lambda t, b: ["--threshold", "otsu"] + true_column(t, b),
    "after+true_column": lambda t, b: true_column(t, b),
    "after+no_rician_correction": lambda t, b: ["--noise", "gaussian"],
    "after+no_median": lambda t, b: ["--denoise", "none"],
    "before+no_median": lambda t, b: BEFORE + ["--denoise", "none"],
    "after+no_cleanup": lambda t, b: ["--max-speck-voxels", "0", "--max-hole-voxels", "0"],
    "before+no_cleanup": lambda t, b: BEFORE + ["--max-speck-voxels", "0", "--max-hole-voxels",
                                                "0"],
}

records = []
t_start = time.time()
if "--sweep-only" not in sys.argv:
    diag = list(VARIANTS)
    for name, vpd in (("cylinders", 20), ("spheres", 10)):
        for blur in (0, 1):
            records += [dict(r, study="diagnosis") for r in case(name, vpd, 10, blur,
                                                                 variants=diag)]
if "--diagnose-only" not in sys.argv:
    vpds = (10, 20) if QUICK else (8, 10, 15, 20, 30)
    for name in ("spheres", "cylinders"):
        for vpd in vpds:
            records += [dict(r, study="vpd") for r in case(name, vpd, 10, 1)]
    snrs = (10,) if QUICK else (5, 10, 20, 50)
    blurs = (0, 1) if QUICK else (0, 0.5, 1, 1.5)
    for snr in snrs:
        for blur in blurs:
            if snr == 10 and blur == 1:
                continue  # in the vpd sweep
            records += [dict(r, study="snr_blur") for r in case("spheres", 20, snr, blur)]
    for modality in ("xmt",):
        for name in ("spheres", "cylinders"):
            records += [dict(r, study="xmt") for r in case(name, 20, 10, 1, modality)]

load = os.getloadavg()
result = dict(
    description="voxpack ingest fidelity on phantoms of MC-packed beds (bench/ingest/fidelity.py)",
    beds=BEDS, truth={k: dict(density=v["stats"]["density"], roi_mm=v["roi"],
                              radius_mm=v["stats"]["radius"]) for k, v in TRUTH.items()},
    before_flags=BEFORE, wall_s=time.time() - t_start, load_average=load,
    records=records)
with open(OUT, "w") as f:
    json.dump(result, f, indent=1, default=float)
print(f"wrote {OUT} ({len(records)} records, {time.time() - t_start:.0f} s, load {load})")
