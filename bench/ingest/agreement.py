#!/usr/bin/python3
"""Voxel agreement between a reference segmentation and an ingested bed.

usage: agreement.py REF SEG.h5
  REF  a bed file (.h5; its /indicator, inside its /mask when present) or a folder of
       binary TIFF slices (non-zero = void), e.g. porous-steel-xct/bw
Prints the reference and ingested porosity, the voxel agreement and the Dice of the void.
"""
import glob
import os
import sys

import h5py
import numpy as np


def load(path):
    if os.path.isdir(path):
        from PIL import Image
        files = sorted(glob.glob(os.path.join(path, "*.tif")))
        return np.stack([np.array(Image.open(f)) for f in files]) > 0, None
    with h5py.File(path, "r") as f:
        ind = f["indicator"][:] > 0
        mask = f["mask"][:] > 0 if "mask" in f else None
    return ind, mask


ref, mask = load(sys.argv[1])
seg, seg_mask = load(sys.argv[2])
if mask is None:
    mask = np.ones_like(ref)
both = ref & seg & mask
print("reference porosity %.4f  ingested porosity (own mask) %.4f  agreement %.4f  dice(void) %.4f"
      % (ref[mask].mean(),
         seg[seg_mask].mean() if seg_mask is not None else seg.mean(),
         (ref[mask] == seg[mask]).mean(),
         2.0 * both.sum() / (ref[mask].sum() + seg[mask].sum())))
