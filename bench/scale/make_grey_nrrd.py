#!/usr/bin/python3
"""Writes an N^3 uint8 XMT-like grey volume (attached raw NRRD) slab by slab: spheres
(solid, grey 180) of radius 10.5 voxels on a cubic grid of period 24 (a periodic tile) in
air (60), inside a column of radius 0.48 N (wall grey 200 outside it), Gaussian noise
sigma 20 (seeded). Memory: one slab. Usage: make_grey_nrrd.py N OUT.nrrd [seed]"""
import sys, numpy as np
n = int(sys.argv[1]); out = sys.argv[2]; seed = int(sys.argv[3]) if len(sys.argv) > 3 else 1
P, R, S = 24, 10.5, 16
rng = np.random.default_rng(seed)
t = np.arange(P, dtype=np.float32) - (P - 1) / 2
tile = (t[:, None, None] ** 2 + t[None, :, None] ** 2 + t[None, None, :] ** 2) < R * R
reps = (n + P - 1) // P
with open(out, "wb") as f:
    f.write((f"NRRD0004\ntype: uint8\ndimension: 3\nsizes: {n} {n} {n}\n"
             f"spacings: 0.1 0.1 0.1\nencoding: raw\n\n").encode())
    y, x = np.mgrid[0:n, 0:n].astype(np.float32)
    c = 0.5 * (n - 1)
    outside = (x - c) ** 2 + (y - c) ** 2 >= (0.48 * n) ** 2
    for z0 in range(0, n, S):
        z1 = min(n, z0 + S)
        slab = np.empty((z1 - z0, n, n), np.float32)
        for k in range(z0, z1):
            solid = np.tile(tile[k % P], (reps, reps))[:n, :n]
            plane = np.where(solid, 180.0, 60.0).astype(np.float32)
            plane[outside] = 200.0
            slab[k - z0] = plane
        slab += rng.normal(0.0, 20.0, size=slab.shape).astype(np.float32)
        f.write(np.clip(np.rint(slab), 0, 255).astype(np.uint8).tobytes())
