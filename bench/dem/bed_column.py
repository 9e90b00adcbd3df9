"""A bed file's arrays and its column (from the mask): shared by bed_structure.py,
crystal_order.py and bulk_exact.py."""
import argparse
from types import SimpleNamespace

import h5py
import numpy as np


def bed_arguments():
    """The scripts' common arguments: BED.h5, D_MM and the bulk margin in d."""
    ap = argparse.ArgumentParser()
    ap.add_argument("bed")
    ap.add_argument("d", type=float)
    ap.add_argument("--bulk-margin-d", type=float, default=3.0)
    return ap


def read_bed(path):
    """indicator, mask (all ones without one), spacing and origin (z, y, x mm), particle
    positions (x, y, z mm) and shape strings of a bed file."""
    with h5py.File(path, "r") as f:
        ind = f["indicator"][...]
        return SimpleNamespace(
            indicator=ind, mask=f["mask"][...] if "mask" in f else np.ones_like(ind),
            spacing=tuple(f.attrs["spacing_mm"]), origin=tuple(f.attrs["origin_mm"]),
            positions=f["particles/position_mm"][...],
            shapes=[s.decode() if isinstance(s, bytes) else str(s)
                    for s in f["particles/shape"][...]])


def column_geometry(mask, spacing_mm, origin_mm):
    """Axis (cx, cy), wall radius (largest extent of the mask about its centroid, plus half a
    voxel) and floor height (the lower face of the first slice holding the mask), in mm."""
    sz, sy, sx = spacing_mm
    oz, oy, ox = origin_mm
    jj, ii = np.nonzero(mask.any(axis=0))
    y = oy + jj * sy
    x = ox + ii * sx
    cy, cx = y.mean(), x.mean()
    radius = np.max(np.hypot(y - cy, x - cx)) + 0.5 * sx
    k0 = next(k for k in range(mask.shape[0]) if mask[k].any())
    return cx, cy, radius, oz + (k0 - 0.5) * sz
