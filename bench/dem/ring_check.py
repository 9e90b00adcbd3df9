#!/usr/bin/env python3
"""Integrity and voidage of a poured bed of rings or trilobes (docs/dem.md, "Rings and
trilobes").

    ring_check.py BED.h5 SPEC [--end-margin-d 1]
    SPEC: ring:d=D,di=DI,l=L or trilobe:d=D,dl=DL,l=L (as given to voxpack pack --shape)

Every particle of the table (position_mm x, y, z; orientation w, x, y, z; axis = body z) is
digitised here from its exact shape on the bed's lattice (voxel centres), independently of
the bed's own digitisation. Prints JSON:
- keep: per particle, the share of its voxels that no other particle also claims (the
  issue's "keeps >= 99 % of its voxels"); min, 1st percentile, median, and those below 0.99;
- labels_agree: per ring, the share of its exact voxels the bed's /labels give to it (checks the
  pose convention and the bed's digitisation);
- bore (rings): per ring, the share of the bore (r < DI/2, |z| <= L/2) that is void in /indicator, and
  how much of it is solid because another ring passes through; rings whose bore is less than
  90 % void;
- linked_pairs (rings): pairs whose centre-line circles (radius (D + DI) / 4, in the ring's
  mid-plane) are linked like chain links: a wall that went through another's wall and out,
  which leaves no overlap and so no trace in the other checks;
- voidage: the void share of /mask between END_MARGIN d above the floor and END_MARGIN d under
  the top of the bed (the highest point of any ring), with the envelope fraction (rings as
  solid cylinders) and the number of particles per m^3 over the same slab.
"""
import argparse
import json
import math

import h5py
import numpy as np


def rotation(q):
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("bed")
    ap.add_argument("spec")
    ap.add_argument("--end-margin-d", type=float, default=1.0)
    a = ap.parse_args()
    kind, _, params = a.spec.partition(":")
    p = {k: float(v) for k, v in (kv.split("=") for kv in params.split(","))}
    if kind not in ("ring", "trilobe"):
        raise SystemExit("ring_check.py: SPEC must be ring:... or trilobe:...")
    a.d, a.l = p["d"], p["l"]
    ro, hl = a.d / 2, a.l / 2
    ri = p["di"] / 2 if kind == "ring" else 0.0
    rl = p.get("dl", 0.6 * a.d) / 2  # trilobe lobe radius (voxpack's default dl = 0.6 d)
    cl = ro - rl                      # trilobe lobe centre distance

    def section(x, y):
        """(solid, bore) of the cross-section at body x, y."""
        rr = x * x + y * y
        if kind == "ring":
            return (rr <= ro * ro) & (rr >= ri * ri), rr < ri * ri
        solid = np.zeros(np.shape(x), bool)
        for k in range(3):
            t = 2 * math.pi * k / 3
            solid |= (x - cl * math.cos(t)) ** 2 + (y - cl * math.sin(t)) ** 2 <= rl * rl
        return solid, np.zeros(np.shape(x), bool)

    f = h5py.File(a.bed, "r")
    X = f["particles/position_mm"][:]
    Q = f["particles/orientation"][:]
    ind = f["indicator"][:]
    labels = f["labels"][:]
    mask = f["mask"][:] if "mask" in f else np.ones_like(ind)
    o = np.asarray(f.attrs["origin_mm"], float)  # z, y, x of voxel (0, 0, 0)'s centre
    h = np.asarray(f.attrs["spacing_mm"], float)
    shape = np.array(ind.shape)
    n = len(X)

    claims = np.zeros(ind.shape, np.uint8)
    own, bores, tops = [], [], []
    reach = math.hypot(ro, hl)
    for i in range(n):
        R = rotation(Q[i])
        c = X[i][::-1]  # z, y, x
        lo = np.maximum(np.floor((c - reach - o) / h).astype(int), 0)
        hi = np.minimum(np.ceil((c + reach - o) / h).astype(int) + 1, shape)
        kz, ky, kx = np.meshgrid(*[np.arange(lo[k], hi[k]) for k in range(3)], indexing="ij")
        pz, py, px = (o[0] + kz * h[0], o[1] + ky * h[1], o[2] + kx * h[2])
        rel = np.stack([px - X[i][0], py - X[i][1], pz - X[i][2]], axis=-1)
        loc = rel @ R  # body frame: R maps body to world, so body = R^T rel
        slab = np.abs(loc[..., 2]) <= hl
        solid, hole = section(loc[..., 0], loc[..., 1])
        wall, bore = slab & solid, slab & hole
        wi = (kz[wall], ky[wall], kx[wall])
        np.add.at(claims, wi, 1)
        own.append(wi)
        bores.append((kz[bore], ky[bore], kx[bore]))
        tops.append((pz[wall]).max() if wall.any() else c[0])

    keep, agree, boreVoid, boreOther = [], [], [], []
    for i in range(n):
        wi = own[i]
        if len(wi[0]) == 0:
            keep.append(0.0)
            agree.append(0.0)
            continue
        keep.append(float(np.mean(claims[wi] == 1)))
        agree.append(float(np.mean(labels[wi] == i + 1)))
        b = bores[i]
        if len(b[0]):
            boreVoid.append(float(np.mean(ind[b] == 1)))
            boreOther.append(float(np.mean((ind[b] == 0) & (labels[b] != i + 1))))
    keep = np.array(keep)
    agree = np.array(agree)
    boreVoid = np.array(boreVoid) if boreVoid else np.array([1.0])

    # Linked centre circles: circle j crosses the disc of circle i exactly once.
    linked = []
    if kind == "ring":
        rc = (ro + ri) / 2
        Rs = [rotation(q) for q in Q]
        for i in range(n):
            ni = Rs[i][:, 2]
            for j in range(i + 1, n):
                if np.sum((X[i] - X[j]) ** 2) > (2 * rc) ** 2:
                    continue
                u, v = Rs[j][:, 0], Rs[j][:, 1]
                # (X_j + rc (cos t u + sin t v) - X_i) . n_i = 0: A cos t + B sin t + C = 0
                A, B, C = rc * u @ ni, rc * v @ ni, (X[j] - X[i]) @ ni
                r = math.hypot(A, B)
                if r < 1e-12 or abs(C) > r:
                    continue
                phi, dt = math.atan2(B, A), math.acos(max(-1.0, min(1.0, -C / r)))
                crossings = 0
                for t in (phi + dt, phi - dt):
                    pt = X[j] + rc * (math.cos(t) * u + math.sin(t) * v)
                    crossings += np.linalg.norm(pt - X[i]) < rc
                if crossings == 1:
                    linked.append([i, j])

    # The slab between the end margins; the floor is the lowest mask voxel's plane.
    zs = o[0] + np.arange(shape[0]) * h[0]
    inMask = mask.reshape(shape[0], -1).sum(axis=1)
    floor = zs[np.argmax(inMask > 0)] - h[0] / 2
    top = max(tops)
    z0, z1 = floor + a.end_margin_d * a.d, top - a.end_margin_d * a.d
    sl = slice(int(np.ceil((z0 - o[0]) / h[0])), int(np.floor((z1 - o[0]) / h[0])) + 1)
    m = mask[sl] > 0
    voidage = float(np.mean(ind[sl][m] == 1))
    slabMm3 = m.sum() * h.prod()
    particleMm3 = float(np.mean([len(w[0]) for w in own])) * h.prod()  # digitised, exact shape
    envMm3 = math.pi * ro * ro * a.l
    # Rings per volume: centres inside the slab (a ring straddling an end counts by its centre).
    inside = (X[:, 2] >= z0) & (X[:, 2] <= z1)
    perM3 = inside.sum() / (slabMm3 * 1e-9) if slabMm3 > 0 else 0.0

    out = {
        "bed": a.bed,
        "shape": a.spec,
        "particle_mm3": particleMm3,
        "particles": n,
        "voxel_mm": float(h[0]),
        "keep": {"min": float(keep.min()), "p01": float(np.percentile(keep, 1)),
                 "median": float(np.median(keep)), "below_0_99": int((keep < 0.99).sum())},
        "labels_agree": {"min": float(agree.min()), "median": float(np.median(agree))},
        "bore": None if kind != "ring" else {"void_median": float(np.median(boreVoid)), "void_min": float(boreVoid.min()),
                 "below_0_9_void": int((boreVoid < 0.9).sum()),
                 "solid_from_other_rings_mean": float(np.mean(boreOther)),
                 "solid_own_labels": int(sum(int(np.sum(labels[b] == i + 1))
                                             for i, b in enumerate(bores))),
                 "linked_pairs": len(linked), "linked": linked[:20]},
        "voidage": {"slab_mm": [float(z0), float(z1)], "voidage": voidage,
                    "particles_in_slab": int(inside.sum()), "particles_per_m3": perM3,
                    "solid_from_count": perM3 * particleMm3 * 1e-9,
                    "envelope_fraction_from_count": perM3 * envMm3 * 1e-9},
    }
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
