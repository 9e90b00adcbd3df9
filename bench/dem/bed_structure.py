#!/usr/bin/env python3
"""Structure of a poured sphere bed (docs/dem.md "Random close packing", "Mean voidage").

    bed_structure.py BED.h5 D_MM [--bulk-margin-d 3] [--rmax-d 2.6] [--bin-d 0.01]

Prints JSON:
- bulk_phi: the voxel solid fraction (indicator 0 inside /mask) of the bulk, the voxels at
  least MARGIN d from the column wall, from the floor and from the bed top (the highest
  particle centre + d/2); bulk_phi_centres: the centres in that region times the sphere
  volume over its volume; bulk_coordination: contacts (centres closer than d) per bulk sphere;
- mean_phi_bed: the whole cross-section between 2 d above the floor and 2 d below the top
  (what Benyahia & O'Neill's mean voidage describes, end effects left out);
  mean_voidage_bed_centres: the same slab from the centres in it (D_MM: a non-sphere's
  volume-equivalent diameter), free of the digitisation error;
- g(r) from the particle centres: reference spheres in the bulk region, neighbours
  anywhere, normalised by the bulk number density and the shell volume; its contact peak
  (position and height in 0.9..1.1 d), its values at sqrt(3) d and 2 d (the split second
  peak) and its minimum between 1.2 and 1.7 d.
The column axis and radius come from the mask (its centroid and largest extent per slice).
"""
import json
import math

import numpy as np

from bed_column import bed_arguments, column_geometry, read_bed


def main():
    ap = bed_arguments()
    ap.add_argument("--rmax-d", type=float, default=2.6)
    ap.add_argument("--bin-d", type=float, default=0.01)
    a = ap.parse_args()
    d = a.d
    bed = read_bed(a.bed)
    ind, mask, pos = bed.indicator, bed.mask, bed.positions
    sz, sy, sx = bed.spacing
    oz, oy, ox = bed.origin
    nz, ny, nx = ind.shape
    cx, cy, radius, floor = column_geometry(mask, (sz, sy, sx), (oz, oy, ox))
    top = pos[:, 2].max() + 0.5 * d
    zc = oz + np.arange(nz) * sz
    yy, xx = np.meshgrid(oy + np.arange(ny) * sy, ox + np.arange(nx) * sx, indexing="ij")
    rr = np.hypot(yy - cy, xx - cx)
    solid = (ind == 0) & (mask != 0)
    m = a.bulk_margin_d * d

    def phi(zlo, zhi, rmax):
        ks = np.nonzero((zc >= zlo) & (zc <= zhi))[0]
        area = (mask[ks] != 0) & (rr[None] < rmax)
        return float((solid[ks] & area).sum() / max(1, area.sum())), int(len(ks))

    bulk_phi, bulk_slices = phi(floor + m, top - m, radius - m)
    bed_phi, bed_slices = phi(floor + 2 * d, top - 2 * d, 1e300)
    # The same slab from the centres in it times the particle volume (pi d^3 / 6: d is the
    # volume-equivalent diameter of a non-sphere): no digitisation error, unbiased on average
    # (the particles cut by the slab's faces balance).
    # The cross-section is the mask's mean area over the slab's slices: column_geometry's
    # radius (the largest extent) reads ~half a voxel large.
    in_slab = (pos[:, 2] >= floor + 2 * d) & (pos[:, 2] <= top - 2 * d)
    ks = np.nonzero((zc >= floor + 2 * d) & (zc <= top - 2 * d))[0]
    area = float((mask[ks] != 0).sum()) / max(1, len(ks)) * sy * sx
    slab_volume = area * max(1e-9, top - floor - 4 * d)
    bed_phi_centres = float(in_slab.sum() * math.pi * d ** 3 / 6 / slab_volume)
    # g(r): reference centres in the bulk region (a shell of rmax_d d around each lies in the bed).
    rc = np.hypot(pos[:, 1] - cy, pos[:, 0] - cx)
    ref = (rc < radius - m) & (pos[:, 2] > floor + m) & (pos[:, 2] < top - m)
    vol_bulk = math.pi * (radius - m) ** 2 * max(1e-9, (top - m) - (floor + m))
    n_bulk = int(ref.sum())
    rho = n_bulk / vol_bulk
    edges = np.arange(0, a.rmax_d * d + 1e-12, a.bin_d * d)
    hist = np.zeros(len(edges) - 1)
    # One pass over the bulk spheres: g(r)'s histogram, the nearest neighbour (contact
    # overlaps show as < 1 d) and the contacts (centres closer than d: every touching pair
    # overlaps a little).
    nn, contacts = [], []
    for p in pos[ref]:
        dist = np.linalg.norm(pos - p, axis=1)
        dist = dist[dist > 1e-9]
        hist += np.histogram(dist[dist < edges[-1]], edges)[0]
        nn.append(np.min(dist) / d)
        contacts.append(int((dist < d).sum()))
    shell = 4.0 / 3.0 * math.pi * (edges[1:] ** 3 - edges[:-1] ** 3)
    g = hist / max(1, n_bulk) / (rho * shell) if n_bulk else hist
    r = 0.5 * (edges[1:] + edges[:-1]) / d

    def at(lo, hi, fn):
        sel = (r >= lo) & (r <= hi)
        i = np.nonzero(sel)[0][fn(g[sel])]
        return float(r[i]), float(g[i])

    peak_r, peak_g = at(0.9, 1.1, np.argmax)
    min_r, min_g = at(1.2, 1.7, np.argmin)
    # The split second peak: the largest g within +-0.03 d of sqrt(3) d and of 2 d.
    s3_r, s3_g = at(math.sqrt(3) - 0.03, math.sqrt(3) + 0.03, np.argmax)
    s2_r, s2_g = at(1.97, 2.03, np.argmax)
    out = {
        "bed": a.bed,
        "d_mm": d,
        "particles": int(len(pos)),
        "column_radius_mm": float(radius),
        "column_D_over_d": float(2 * radius / d),
        "floor_mm": float(floor),
        "top_mm": float(top),
        "bulk_margin_d": a.bulk_margin_d,
        "bulk_phi": bulk_phi,
        "bulk_slices": bulk_slices,
        "bulk_reference_spheres": n_bulk,
        # Centres counted in the bulk region times a sphere's volume: no voxel error, and the
        # overlaps' double-counted lenses (~1e-3 at 0.4 % d) stay in.
        "bulk_phi_centres": rho * math.pi * d ** 3 / 6,
        "bulk_coordination": float(np.mean(contacts)) if contacts else None,
        "mean_phi_bed": bed_phi,
        "mean_voidage_bed": 1 - bed_phi,
        "mean_voidage_bed_centres": 1 - bed_phi_centres,
        "bed_slices": bed_slices,
        "nearest_neighbour_median_d": float(np.median(nn)) if nn else None,
        "g_contact_peak_r_d": peak_r,
        "g_contact_peak": peak_g,
        "g_min_r_d": min_r,
        "g_min": min_g,
        "g_sqrt3_r_d": s3_r,
        "g_sqrt3": s3_g,
        "g_2d_r_d": s2_r,
        "g_2d": s2_g,
        "g_r_d": [round(float(v), 4) for v in r],
        "g": [round(float(v), 4) for v in g],
    }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
