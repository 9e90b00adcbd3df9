"""The column of a bed file, from its mask: shared by bed_structure.py and crystal_order.py."""
import numpy as np


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
