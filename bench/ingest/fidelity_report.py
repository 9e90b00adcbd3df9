#!/usr/bin/python3
"""Tables (markdown on stdout) and the figure of bench/results/ingest_fidelity.json.

usage: fidelity_report.py RESULTS.json FIGURE.png
"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

res = json.load(open(sys.argv[1]))
recs = res["records"]


def pick(**kw):
    return [r for r in recs if all(r.get(k) == v for k, v in kw.items())]


def fmt(x, p=4):
    return "n/a" if x is None else f"{x:+.{p}f}"


def goal(r):
    if r["voxels_per_d"] >= 15 and r["snr"] >= 10 and r["blur_voxels"] <= 1:
        return 0.005
    if r["voxels_per_d"] == 10 and r["snr"] >= 10 and r["blur_voxels"] <= 1:
        return 0.015
    return None


def dcols(r, g):
    q = pick(study=r["study"], bed=r["bed"], modality=r["modality"],
             voxels_per_d=r["voxels_per_d"], snr=r["snr"], blur_voxels=r["blur_voxels"],
             variant="after+deconv")
    if not q:
        return " | | |"
    ok = "" if g is None else ("met" if abs(q[0]["bias"]) < g else f"**missed** (< {g})")
    return f" {fmt(q[0]['bias'])} | {q[0]['near_wall_rmse']:.3f} | {ok} |"


print("### Sweep (MRI unless noted; bias = ingested - truth density; RMSE = first d of the "
      "radial profile)\n")
deconv = any(r["variant"] == "after+deconv" and r["study"] != "deconv" for r in recs)
print("| study | bed | modality | voxels/d | SNR | blur (voxel) | bias before | bias after | "
      "RMSE before | RMSE after | radius err after (voxel) | goal |" +
      (" bias `--deconvolve` | RMSE `--deconvolve` | goal `--deconvolve` |" if deconv else ""))
print("|---|---|---|---|---|---|---|---|---|---|---|---|" + ("---|---|---|" if deconv else ""))
for r in recs:
    if r["variant"] != "after" or r["study"] == "diagnosis":
        continue
    b = [q for q in pick(study=r["study"], bed=r["bed"], modality=r["modality"],
                         voxels_per_d=r["voxels_per_d"], snr=r["snr"],
                         blur_voxels=r["blur_voxels"], variant="before")]
    b = b[0] if b else None
    g = goal(r)
    ok = "" if g is None else ("met" if abs(r["bias"]) < g else f"**missed** (< {g})")
    print(f"| {r['study']} | {r['bed']} | {r['modality']} | {r['voxels_per_d']} | {r['snr']:g} | "
          f"{r['blur_voxels']:g} | {fmt(b['bias'] if b else None)} | {fmt(r['bias'])} | "
          f"{b['near_wall_rmse']:.3f} | {r['near_wall_rmse']:.3f} | "
          f"{fmt(r['radius_err_voxels'], 3)} | {ok} |" + (dcols(r, g) if deconv else ""))

print("\n### Diagnosis (MRI, SNR 10): bias per variant\n")
cases = sorted({(r["bed"], r["voxels_per_d"], r["blur_voxels"]) for r in pick(study="diagnosis")})
variants = []
for r in pick(study="diagnosis"):
    if r["variant"] not in variants:
        variants.append(r["variant"])
print("| variant | " + " | ".join(f"{b} {v}/d blur {bl:g}" for b, v, bl in cases) + " |")
print("|---|" + "---|" * len(cases))
for v in variants:
    row = []
    for b, vpd, bl in cases:
        q = pick(study="diagnosis", bed=b, voxels_per_d=vpd, blur_voxels=bl, variant=v)
        row.append(f"{q[0]['bias']:+.4f} ({q[0]['near_wall_rmse']:.3f})" if q else "")
    print(f"| {v} | " + " | ".join(row) + " |")

fig, ax = plt.subplots(1, 3, figsize=(15, 4.4))
for bed, c in (("spheres", "C0"), ("cylinders", "C1")):
    for v, ls in (("before", "--"), ("after", "-")):
        q = sorted(pick(study="vpd", bed=bed, variant=v), key=lambda r: r["voxels_per_d"])
        if q:
            ax[0].plot([r["voxels_per_d"] for r in q], [r["bias"] for r in q], ls, color=c,
                       marker="o", label=f"{bed} {v}")
ax[0].axhspan(-0.005, 0.005, color="g", alpha=0.12, label="goal +-0.005 (>= 15/d)")
ax[0].axhline(0, color="k", lw=0.5)
ax[0].set_xlabel("voxels per particle diameter")
ax[0].set_ylabel("density bias (ingested - truth)")
ax[0].set_title("MRI, SNR 10, blur 1 voxel")
ax[0].legend(fontsize=7)
for vpd, mk in ((10, "s"), (15, "o")):
    for v, ls in (("before", "--"), ("after", "-")):
        for snr, c in ((5, "C3"), (10, "C0"), (20, "C2"), (50, "C4")):
            q = [r for r in recs if r["bed"] == "spheres" and r["modality"] == "mri" and
                 r["voxels_per_d"] == vpd and r["snr"] == snr and r["variant"] == v and
                 r["study"] in ("snr_blur", "vpd")]
            q = sorted(q, key=lambda r: r["blur_voxels"])
            if q and vpd == 15:
                ax[1].plot([r["blur_voxels"] for r in q], [r["bias"] for r in q], ls, color=c,
                           marker=mk, label=f"SNR {snr} {v}" if v == "after" else None)
ax[1].axhspan(-0.005, 0.005, color="g", alpha=0.12)
ax[1].axhline(0, color="k", lw=0.5)
ax[1].set_xlabel("blur sigma (voxels)")
ax[1].set_title("spheres, MRI, 15 voxels per d (dashed: before)")
ax[1].legend(fontsize=7)
for bed, c in (("spheres", "C0"), ("cylinders", "C1")):
    q = pick(study="vpd", bed=bed, voxels_per_d=20, variant="after")
    qb = pick(study="vpd", bed=bed, voxels_per_d=20, variant="before")
    if q:
        x = (np.arange(10) + 0.5) * 0.1
        ax[2].plot(x, q[0]["truth_profile"], "k-" if bed == "spheres" else "k:",
                   label=f"{bed} truth")
        ax[2].plot(x, q[0]["profile"], "-", color=c, marker=".", label=f"{bed} after")
        if qb:
            ax[2].plot(x, qb[0]["profile"], "--", color=c, label=f"{bed} before")
ax[2].set_xlabel("distance from the wall (d)")
ax[2].set_ylabel("solid fraction")
ax[2].set_title("near-wall profile, MRI 20/d, SNR 10, blur 1")
ax[2].legend(fontsize=7)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=110)
