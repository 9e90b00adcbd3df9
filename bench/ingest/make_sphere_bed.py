#!/usr/bin/python3
"""Writes a bed file of random non-overlapping spheres in a cylinder (h5py, SPEC layout).

usage: make_sphere_bed.py N SPHERE_RADIUS_VOX OUT.h5 [VOXEL_MM=0.2] [SEED=1]
N^3 voxels; column radius N/2 - 4 voxels around the lattice centre; mask = voxel centres
strictly inside. Random sequential addition, 20000 attempts. Prints count and porosity.
"""
import json
import sys

import h5py
import numpy as np

n = int(sys.argv[1])
rad = float(sys.argv[2])
out = sys.argv[3]
voxel = float(sys.argv[4]) if len(sys.argv) > 4 else 0.2
rng = np.random.default_rng(int(sys.argv[5]) if len(sys.argv) > 5 else 1)
R = n / 2 - 4
c = (n - 1) / 2
z, y, x = np.mgrid[0:n, 0:n, 0:n]
mask = (x - c) ** 2 + (y - c) ** 2 < R * R
centres = []
for _ in range(20000):
    p = np.array([rng.uniform(0, n), c + rng.uniform(-R, R), c + rng.uniform(-R, R)])
    if (p[1] - c) ** 2 + (p[2] - c) ** 2 > (R - rad) ** 2:
        continue
    if all(np.sum((p - q) ** 2) >= (2 * rad) ** 2 for q in centres):
        centres.append(p)
ind = np.ones((n, n, n), np.uint8)
for p in centres:
    ind[(z - p[0]) ** 2 + (y - p[1]) ** 2 + (x - p[2]) ** 2 < rad * rad] = 0
print("spheres %d porosity %.4f" % (len(centres), ind[mask].mean()))
with h5py.File(out, "w") as f:
    f.attrs["format"] = "voxpack-bed"
    f.attrs["format_version"] = 1
    f.attrs["spacing_mm"] = np.array([voxel] * 3)
    f.attrs["origin_mm"] = np.zeros(3)
    f.attrs["provenance"] = json.dumps({"command": "make_sphere_bed.py", "argv": sys.argv})
    f.create_dataset("indicator", data=ind, chunks=True, compression="gzip")
    f.create_dataset("mask", data=mask.astype(np.uint8), chunks=True, compression="gzip")
