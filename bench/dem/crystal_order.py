#!/usr/bin/env python3
"""Crystalline order of a poured sphere bed (docs/dem.md "Random close packing").

    crystal_order.py BED.h5 D_MM [--bulk-margin-d 3] [--cutoff-d 1.35]

A random close packing has no crystallites to speak of; a bed denser than 0.64 either
holds overlaps or has begun to order. This reads the particle centres and, for each
sphere, Steinhardt's local bond order q6 (neighbours closer than CUTOFF d, the minimum
after g(r)'s contact peak). Two neighbours' normalised q6 vectors with a dot product
above 0.7 form a solid-like bond, and a sphere with at least 7 of them counts as
crystal-like (ten Wolde, Ruiz-Montero & Frenkel 1996; the criterion used for hard-sphere
packings, e.g. Anikeenko & Medvedev 2007, Klumov et al. 2011).

Prints JSON: the bulk's (>= MARGIN d from the wall, the floor and the bed top) sphere
count, mean q6, global Q6, crystal-like fraction; and the crystal-like fraction in bands
of 1 d from the wall (every sphere >= MARGIN d from floor and top).
"""
import json
import math

import h5py
import numpy as np
from scipy.spatial import cKDTree
from scipy.special import sph_harm

from bed_column import bed_arguments, column_geometry


def main():
    ap = bed_arguments()
    ap.add_argument("--cutoff-d", type=float, default=1.35)
    a = ap.parse_args()
    d = a.d
    with h5py.File(a.bed, "r") as f:
        pos = f["particles/position_mm"][...]
        cx, cy, radius, floor = column_geometry(f["mask"][...], f.attrs["spacing_mm"],
                                                f.attrs["origin_mm"])
    top = pos[:, 2].max() + 0.5 * d
    n = len(pos)
    tree = cKDTree(pos)
    pairs = tree.query_pairs(a.cutoff_d * d, output_type="ndarray")
    # q6m per sphere: the mean of Y6m over its bonds, normalised to unit length.
    q6 = np.zeros((n, 13), dtype=complex)
    nb = np.zeros(n, dtype=int)
    for i, j in ((pairs[:, 0], pairs[:, 1]), (pairs[:, 1], pairs[:, 0])):
        v = pos[j] - pos[i]
        r = np.linalg.norm(v, axis=1)
        polar = np.arccos(np.clip(v[:, 2] / r, -1, 1))
        azim = np.arctan2(v[:, 1], v[:, 0])
        for m in range(-6, 7):
            np.add.at(q6[:, m + 6], i, sph_harm(m, 6, azim, polar))
        np.add.at(nb, i, 1)
    has = nb > 0
    q6[has] /= nb[has, None]
    q6_local = np.sqrt(4 * math.pi / 13 * np.sum(np.abs(q6) ** 2, axis=1))
    unit = np.zeros_like(q6)
    norm = np.linalg.norm(q6, axis=1)
    unit[norm > 0] = q6[norm > 0] / norm[norm > 0, None]
    dots = np.real(np.sum(unit[pairs[:, 0]] * np.conj(unit[pairs[:, 1]]), axis=1))
    solid_bonds = np.zeros(n, dtype=int)
    sb = dots > 0.7
    np.add.at(solid_bonds, pairs[sb, 0], 1)
    np.add.at(solid_bonds, pairs[sb, 1], 1)
    crystal = solid_bonds >= 7

    m = a.bulk_margin_d * d
    from_wall = radius - np.hypot(pos[:, 0] - cx, pos[:, 1] - cy)
    height_ok = (pos[:, 2] >= floor + m) & (pos[:, 2] <= top - m)
    bulk = height_ok & (from_wall >= m)
    glob = q6[bulk].mean(axis=0)
    out = {
        "bed": a.bed, "d_mm": d, "spheres": int(n), "cutoff_d": a.cutoff_d,
        "bulk_margin_d": a.bulk_margin_d, "bulk_spheres": int(bulk.sum()),
        "bulk_mean_neighbours": float(nb[bulk].mean()),
        "bulk_mean_q6": float(q6_local[bulk].mean()),
        "bulk_global_Q6": float(math.sqrt(4 * math.pi / 13 * np.sum(np.abs(glob) ** 2))),
        "bulk_crystal_fraction": float(crystal[bulk].mean()),
        "crystal_fraction_by_wall_distance_d": [],
    }
    for b in range(int(radius / d) + 1):
        sel = height_ok & (from_wall >= b * d) & (from_wall < (b + 1) * d)
        if sel.sum() == 0:
            continue
        out["crystal_fraction_by_wall_distance_d"].append(
            {"from_d": b, "to_d": b + 1, "spheres": int(sel.sum()),
             "crystal_fraction": float(crystal[sel].mean()),
             "mean_q6": float(q6_local[sel].mean())})
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
