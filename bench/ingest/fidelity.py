#!/usr/bin/python3
"""Ingest fidelity: density bias and near-wall profile error of `voxpack ingest` on phantoms
of known beds, before (Otsu + voxel-level column circle) and after (the default pipeline).

usage: fidelity.py VOXPACK WORKDIR OUT.json [--study sweep|diagnosis|deconv|all] [--quick]
                   [--deconv N]   (the sweep also runs `--deconvolve N`: variant after+deconv)
       fidelity.py VOXPACK WORKDIR OUT.json --case BED,VPD,SNR,BLUR,MODALITY[,SEED] [--diag]
                   (--case may be repeated; --goal: the sweep's cases that carry a goal,
                   [--seeds 3,4,5] noise seeds of --goal, default 3; --diag: the diagnosis
                   variants instead of after/before)
                   [--variants after,before,...] (run only these variants)

Beds, packed once into WORKDIR by `voxpack pack --mode mc --seed 1` (the lattice of the bed
file, 30 voxels per d, is the truth; small on purpose so that the whole sweep fits in
minutes on 2 shared cores):
  spheres    d 3 mm in a 15 mm column (D = 5 d), 24 mm of bed, 0.1 mm voxels
  cylinders  the paper's pellets d 5.4 x l 3.8 mm in its 43.3 mm column, 32 mm of bed,
             0.18 mm voxels
Each case: `voxpack phantom --voxel-size d/vpd --blur-mm b*voxel --snr S --seed 3` (one
noise seed per case), then `voxpack ingest` per variant. Measured here with numpy on the
bed files (the same quantities as `voxpack stats --roi-mm`, without a process per bed):
  ROI      slices of the truth's packed region (solid share >= half its peak), one d in
           from each end, as z in mm; each bed counted over the voxels whose centre is in
           the ROI and in its own mask (the ingested bed in the column it fitted)
  bias     ingested - truth packing density over the ROI
  wall     radial profile in bins of 0.1 d of distance from the truth's wall (truth axis and
           area-equivalent radius), each bed in its own mask; near_wall_rmse over the first
           d (10 bins), an empty bin reading 0
"""
import json
import os
import subprocess
import sys
import time

import h5py
import numpy as np

VOX = os.path.abspath(sys.argv[1])
WORK = sys.argv[2]
OUT = sys.argv[3]
ARGS = sys.argv[4:]
STUDY = ARGS[ARGS.index("--study") + 1] if "--study" in ARGS else "sweep"
QUICK = "--quick" in ARGS
os.makedirs(WORK, exist_ok=True)

BEDS = {
    # 24 mm of bed: a ROI of ~5 d (12 mm before 2026-12-06: a ROI of 1 d).
    "spheres": dict(d=3.0, shape="sphere:d=3", container="cylinder:d=15,h=26", fill=24.0,
                    voxel=0.1),
    # 32 mm of bed: the ROI (packed region less 1 d at each end) is ~3 d. The 16 mm
    # bed used before 2026-12-06 left a 1.1 mm ROI (6 slices at 20 voxels per d).
    "cylinders": dict(d=5.4, shape="cylinder:d=5.4,l=3.8", container="cylinder:d=43.3,h=34",
                      fill=32.0, voxel=0.18),
    # The fidelity tests' bed (tests/ingest/test_fidelity.cpp), for --case only.
    "testbed": dict(d=2.0, shape="sphere:d=2", container="cylinder:d=10,h=9", fill=8.0,
                    voxel=0.1),
}
BEFORE = ["--threshold", "otsu", "--no-refine-column"]


def run(args):
    t0 = time.time()
    r = subprocess.run([VOX] + args, capture_output=True, text=True, timeout=600)
    if r.returncode != 0:
        raise RuntimeError(" ".join(args) + "\n" + r.stderr)
    return r, time.time() - t0


def load(path):
    with h5py.File(path, "r") as f:
        ind = f["indicator"][...]
        mask = f["mask"][...] if "mask" in f else np.ones_like(ind)
        sp = np.array(f.attrs["spacing_mm"], dtype=float)
        org = np.array(f.attrs["origin_mm"], dtype=float)
    return ind, mask, sp, org


class Truth:
    def __init__(self, name):
        b = BEDS[name]
        self.name, self.d = name, b["d"]
        self.path = os.path.join(WORK, f"{name}_truth.h5")
        if not os.path.exists(self.path):
            _, s = run(["-q", "--threads", "2", "pack", "--mode", "mc", "--shape", b["shape"],
                        "--container", b["container"], "--voxel-size", str(b["voxel"]),
                        "--fill-height", str(b["fill"]), "--seed", "1", "-o", self.path])
            print(f"packed {name} in {s:.0f} s", flush=True)
        ind, mask, sp, org = load(self.path)
        inm = mask.sum(axis=(1, 2)).astype(float)
        sol = ((ind == 0) & (mask == 1)).sum(axis=(1, 2)) / np.maximum(inm, 1)
        ks = np.nonzero(sol >= 0.5 * sol.max())[0]
        self.roi = (org[0] + ks[0] * sp[0] + self.d, org[0] + ks[-1] * sp[0] - self.d)
        m = mask[mask.shape[0] // 2]
        j, i = np.nonzero(m)
        self.cx, self.cy = org[2] + i.mean() * sp[2], org[1] + j.mean() * sp[1]
        self.radius = np.sqrt(m.sum() / np.pi) * sp[2]
        self.density, self.profile = self.measure(self.path)

    def column_flag(self):
        return ["--column", f"{self.cx:.5f},{self.cy:.5f},{self.radius:.5f}"]

    def measure(self, path):
        ind, mask, sp, org = load(path)
        z = org[0] + np.arange(ind.shape[0]) * sp[0]
        ks = np.nonzero((z >= self.roi[0]) & (z <= self.roi[1]))[0]
        ind, mask = ind[ks[0]:ks[-1] + 1], mask[ks[0]:ks[-1] + 1].astype(bool)
        solid = (ind == 0) & mask
        density = solid.sum() / mask.sum()
        y = org[1] + np.arange(ind.shape[1]) * sp[1]
        x = org[2] + np.arange(ind.shape[2]) * sp[2]
        r = np.hypot(x[None, :] - self.cx, y[:, None] - self.cy)
        b = np.floor((self.radius - r) / (0.1 * self.d)).astype(int)
        prof = []
        for k in range(10):
            sel = (b == k)[None, :, :] & mask
            n = sel.sum()
            prof.append(float((solid & sel).sum() / n) if n else 0.0)
        return float(density), np.array(prof)


TRUTHS = {}


def truth(name):
    if name not in TRUTHS:
        TRUTHS[name] = Truth(name)
    return TRUTHS[name]


def case(name, vpd, snr, blur_vox, modality, variants, study, seed=3):
    t = truth(name)
    voxel = t.d / vpd
    tag = f"{name}_{modality}_v{vpd}_s{snr}_b{blur_vox}"
    img = os.path.join(WORK, tag + ".nrrd")
    run(["-q", "--threads", "2", "phantom", t.path, "--modality", modality, "--snr", str(snr),
         "--blur-mm", f"{blur_vox * voxel:.6f}", "--voxel-size", f"{voxel:.6f}", "--seed",
         str(seed), "-o", img])
    recs = []
    raw = None
    for v, extra in variants:
        seg = os.path.join(WORK, f"{tag}_{v}.h5")
        flags = extra(t) if callable(extra) else extra
        src = img
        if "--slab-voxels" in flags:  # the streamed reader needs raw encoding
            raw = raw or raw_nrrd(img)
            src = raw
        r, secs = run(["--threads", "2", "ingest", src, "-o", seg, "--json"] + flags)
        rep = json.loads(r.stdout)
        dens, prof = t.measure(seg)
        col = rep["column"]
        rec = dict(study=study, bed=name, modality=modality, voxels_per_d=vpd, snr=snr, seed=seed,
                   blur_voxels=blur_vox, voxel_mm=voxel, variant=v, flags=flags,
                   truth_density=t.density, density=dens, bias=dens - t.density,
                   near_wall_rmse=float(np.sqrt(np.mean((prof - t.profile) ** 2))),
                   profile=prof.tolist(), truth_profile=t.profile.tolist(),
                   column_found=col["found"],
                   radius_err_voxels=((col.get("radius_mm", float("nan")) - t.radius) / voxel
                                      if col["found"] else None),
                   threshold=rep["threshold"]["method"], quality=rep.get("quality"),
                   levels_note=(rep["threshold"].get("levels") or rep.get("phases") or {}).get(
                       "note"),
                   ingest_wall_s=secs)
        print(json.dumps({k: rec[k] for k in ("study", "bed", "modality", "voxels_per_d", "snr",
                                                "blur_voxels", "seed", "variant", "bias",
                                                "near_wall_rmse", "radius_err_voxels")}),
              flush=True)
        recs.append(rec)
        os.remove(seg)
    os.remove(img)
    if raw:
        os.remove(raw)
    return recs


def raw_nrrd(path):
    """A raw-encoded copy of the phantom's attached gzip NRRD (the streamed path's input)."""
    import gzip
    data = open(path, "rb").read()
    head, body = data.split(b"\n\n", 1)
    head = head.replace(b"encoding: gzip", b"encoding: raw")
    out = path[:-5] + "_raw.nrrd"
    with open(out, "wb") as f:
        f.write(head + b"\n\n" + gzip.decompress(body))
    return out


STD = [("after", []), ("before", BEFORE)]
DECONV = ARGS[ARGS.index("--deconv") + 1] if "--deconv" in ARGS else None
SWEEP = STD + ([("after+deconv", ["--deconvolve", DECONV])] if DECONV else [])
DIAG = STD + [
    ("after+true_column", lambda t: t.column_flag()),
    ("before+true_column", lambda t: ["--threshold", "otsu"] + t.column_flag()),
    ("after+gaussian_levels", ["--noise", "gaussian"]),
    ("after+no_median", ["--denoise", "none"]),
    ("before+no_median", BEFORE + ["--denoise", "none"]),
    ("after+column_aim", ["--volume-region", "column"]),
    ("after+phase_tail", ["--phase-level", "tail"]),
    # The phantom's wall is 4 truth voxels thick (voxpack phantom's default), known here.
    ("after+wall_prior", lambda t: ["--column-wall-mm", f"{4 * BEDS[t.name]['voxel']:g}"]),
    ("after+no_cleanup", ["--max-speck-voxels", "0", "--max-hole-voxels", "0"]),
    ("before+no_cleanup", BEFORE + ["--max-speck-voxels", "0", "--max-hole-voxels", "0"]),
    # The streamed path (forced by --slab-voxels): the volume threshold from a sample slab
    # and whole-bed sums (docs/scale.md), with the true column, with the column fitted on
    # the stream (the default), and Otsu.
    ("streamed", lambda t: t.column_flag() + ["--slab-voxels", "16"]),
    ("streamed+auto_column", ["--slab-voxels", "16"]),
    ("streamed+otsu", lambda t: ["--threshold", "otsu"] + t.column_flag() +
     ["--slab-voxels", "16"]),
]

records = []
t_start = time.time()


def save():
    result = dict(
        description="voxpack ingest fidelity on phantoms of MC-packed beds "
                    "(bench/ingest/fidelity.py; one noise seed per case, one packed bed per "
                    "shape)",
        command=" ".join(sys.argv), beds=BEDS,
        truth={k: dict(density=v.density, roi_mm=v.roi, radius_mm=v.radius,
                       profile=v.profile.tolist()) for k, v in TRUTHS.items()},
        before_flags=BEFORE, wall_s=time.time() - t_start, load_average=os.getloadavg(),
        records=records)
    with open(OUT, "w") as f:
        json.dump(result, f, indent=1, default=float)


ONLY = ARGS[ARGS.index("--variants") + 1].split(",") if "--variants" in ARGS else None
if ONLY:
    STD = [v for v in STD if v[0] in ONLY]
    DIAG = [v for v in DIAG if v[0] in ONLY]
    SWEEP = [v for v in SWEEP if v[0] in ONLY]


def goal_cases():
    """The sweep's cases that carry a goal (>= 10 voxels per d, SNR >= 10, blur <= 1)."""
    out = [(n, v, 10, 1, "mri") for n in ("spheres", "cylinders") for v in (10, 15, 20, 30)]
    out += [("spheres", v, s, b, "mri") for v in (10, 15) for s in (10, 20, 50)
            for b in (0, 0.5, 1) if not (s == 10 and b == 1)]
    out += [(n, v, 10, 1, "xmt") for n in ("spheres", "cylinders") for v in (10, 20)]
    return out


ADHOC = [a.split(",") for k, a in zip(ARGS, ARGS[1:]) if k == "--case"]
if "--goal" in ARGS:
    seeds = ARGS[ARGS.index("--seeds") + 1].split(",") if "--seeds" in ARGS else ["3"]
    ADHOC += [[str(x) for x in c] + [sd] for sd in seeds for c in goal_cases()]
for c in ADHOC:  # ad-hoc cases: BED,VPD,SNR,BLUR,MODALITY[,SEED], variants after/before
    records += case(c[0], int(c[1]), float(c[2]), float(c[3]), c[4],
                    DIAG if "--diag" in ARGS else STD, "adhoc",
                    seed=int(c[5]) if len(c) > 5 else 3)
    save()
    STUDY = "none"
if STUDY in ("diagnosis", "all"):
    for name, vpd, blur in (("cylinders", 20, 0), ("cylinders", 20, 1), ("spheres", 10, 1)):
        records += case(name, vpd, 10, blur, "mri", DIAG, "diagnosis")
        save()
if STUDY in ("sweep", "all"):
    vpds = (10, 20) if QUICK else (8, 10, 15, 20, 30)
    for name in ("spheres", "cylinders"):
        for vpd in vpds:
            records += case(name, vpd, 10, 1, "mri", SWEEP, "vpd")
            save()
    snrs = (10,) if QUICK else (5, 10, 20, 50)
    blurs = (0, 1) if QUICK else (0, 0.5, 1, 1.5)
    for vpd in ((15,) if QUICK else (10, 15)):
        for snr in snrs:
            for blur in blurs:
                if snr == 10 and blur == 1:
                    continue  # in the vpd sweep
                records += case("spheres", vpd, snr, blur, "mri", SWEEP, "snr_blur")
                save()
    for name in ("spheres", "cylinders"):
        for vpd in (10, 20):
            records += case(name, vpd, 10, 1, "xmt", SWEEP, "xmt")
            save()
if STUDY == "deconv":  # where deconvolution should help most: coarse, blurred, high SNR
    DEC = STD + [("after+deconv", ["--deconvolve", "10"])]
    for name, vpd, blur in (("spheres", 10, 1), ("spheres", 15, 1.5), ("cylinders", 20, 1)):
        for snr in (10, 50):
            records += case(name, vpd, snr, blur, "mri", DEC, "deconv")
            save()
save()
print(f"wrote {OUT} ({len(records)} records, {time.time() - t_start:.0f} s, "
      f"load {os.getloadavg()})")
