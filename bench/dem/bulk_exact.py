#!/usr/bin/env python3
"""The bulk solid fraction of a sphere bed three ways, to separate the digitisation from the
packing (docs/dem.md "Random close packing").

    bulk_exact.py BED.h5 D_MM [--bulk-margin-d 3] [--points 20000000] [--seed 1]

The bulk region is bed_structure.py's: the voxel slices whose centre lies at least MARGIN d
above the floor and below the bed top (highest centre + d/2), and r < R - MARGIN d about the
mask's axis. Prints JSON:
- phi_voxels: the bed's voxels in that region (what bed_structure.py calls bulk_phi);
- phi_union: the same region's volume fraction inside the union of the exact spheres (the
  particle table), by Monte Carlo with POINTS uniform points (seeded) and its standard error;
  the voxels' continuum limit, so phi_voxels - phi_union is the digitisation error;
- phi_sum: the exact sphere-region intersection volumes summed, overlaps counted twice (by the
  same points: the mean number of spheres covering a point); phi_sum - phi_union is the
  overlaps' lens volume;
- phi_centres: the centres in the region times pi d^3 / 6 over its volume (bed_structure.py's
  bulk_phi_centres), with its Poisson error, and the spheres the region holds whole or cut.
"""
import json
import math

import numpy as np
from scipy.spatial import cKDTree

from bed_column import bed_arguments, column_geometry, read_bed


def main():
    ap = bed_arguments()
    ap.add_argument("--points", type=int, default=20_000_000)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    bed = read_bed(a.bed)
    if any(not s.startswith("sphere:") for s in bed.shapes):
        raise SystemExit("bulk_exact.py: spheres only")
    d, ind, mask, pos = a.d, bed.indicator, bed.mask, bed.positions
    (sz, sy, sx), (oz, oy, ox) = bed.spacing, bed.origin
    nz, ny, nx = ind.shape
    cx, cy, radius, floor = column_geometry(mask, (sz, sy, sx), (oz, oy, ox))
    top = pos[:, 2].max() + 0.5 * d
    m = a.bulk_margin_d * d
    zc = oz + np.arange(nz) * sz
    ks = np.nonzero((zc >= floor + m) & (zc <= top - m))[0]
    rmax = radius - m
    # The voxels: bed_structure.py's rule, slice by slice.
    yy, xx = np.meshgrid(oy + np.arange(ny) * sy, ox + np.arange(nx) * sx, indexing="ij")
    area = (mask[ks] != 0) & (np.hypot(yy - cy, xx - cx)[None] < rmax)
    solid = (ind[ks] == 0) & area
    phi_vox = float(solid.sum() / max(1, area.sum()))
    # The continuum over the same slab (the slices' full thickness) and disc.
    z0, z1 = zc[ks[0]] - 0.5 * sz, zc[ks[-1]] + 0.5 * sz
    rng = np.random.default_rng(a.seed)
    tree = cKDTree(pos)
    inside = 0
    covered = 0
    left = a.points
    while left > 0:
        n = min(left, 1_000_000)
        left -= n
        rho = rmax * np.sqrt(rng.random(n))
        th = 2 * math.pi * rng.random(n)
        pts = np.column_stack([cx + rho * np.cos(th), cy + rho * np.sin(th),
                               z0 + (z1 - z0) * rng.random(n)])
        # One query gives both: the spheres covering each point (the sum) and whether any
        # does (the union).
        hits = tree.query_ball_point(pts, 0.5 * d, return_length=True)
        inside += int((hits > 0).sum())
        covered += int(hits.sum())
    p = inside / a.points
    vol = math.pi * rmax * rmax * (z1 - z0)
    rc = np.hypot(pos[:, 0] - cx, pos[:, 1] - cy)
    in_region = (rc < rmax) & (pos[:, 2] >= z0) & (pos[:, 2] <= z1)
    n_c = int(in_region.sum())
    vs = math.pi * d ** 3 / 6
    touching = (rc < rmax + 0.5 * d) & (pos[:, 2] >= z0 - 0.5 * d) & (pos[:, 2] <= z1 + 0.5 * d)
    json.dump({
        "bed": a.bed, "d_mm": d, "bulk_margin_d": a.bulk_margin_d,
        "region": {"z0_mm": float(z0), "z1_mm": float(z1), "r_max_mm": float(rmax),
                   "axis_xy_mm": [float(cx), float(cy)], "volume_mm3": vol,
                   "slices": int(len(ks)), "voxels": int(area.sum())},
        "phi_voxels": phi_vox,
        "phi_union": p, "phi_union_se": math.sqrt(p * (1 - p) / a.points),
        "phi_sum": covered / a.points,
        "phi_centres": n_c * vs / vol, "phi_centres_poisson_se": math.sqrt(max(1, n_c)) * vs / vol,
        "centres_in_region": n_c, "spheres_meeting_region": int(touching.sum()),
        "points": a.points, "seed": a.seed,
    }, __import__("sys").stdout, indent=1)
    print()


if __name__ == "__main__":
    main()
