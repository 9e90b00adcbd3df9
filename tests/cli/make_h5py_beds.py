"""Writes bed files by hand with h5py, following the bed table of docs/interfaces.md, plus broken variants.

Usage: make_h5py_beds.py OUTDIR. Prints the exact porosity of good.h5 on stdout.
"""
import os
import sys

import h5py
import numpy as np


def write(path, indicator, mask=None, spacing=(0.2, 0.2, 0.2), origin=(0.0, 0.0, 0.0),
          fmt="voxpack-bed", version=1, extra=None):
    with h5py.File(path, "w") as f:
        if fmt is not None:
            f.attrs["format"] = fmt
        if version is not None:
            f.attrs["format_version"] = version
        f.attrs["spacing_mm"] = np.asarray(spacing, dtype=np.float64)
        f.attrs["origin_mm"] = np.asarray(origin, dtype=np.float64)
        f.attrs["provenance"] = '{"writer": "h5py by hand"}'
        if indicator is not None:
            f.create_dataset("indicator", data=indicator, chunks=True, compression="gzip")
        if mask is not None:
            f.create_dataset("mask", data=mask, chunks=True, compression="gzip")
        if extra:
            extra(f)


def main(out):
    rng = np.random.default_rng(7)
    ind = (rng.random((12, 10, 9)) < 0.37).astype(np.uint8)
    mask = np.zeros_like(ind)
    mask[:, 1:9, 1:8] = 1
    def particles(f):
        g = f.create_group("particles")
        g.create_dataset("position_mm", data=np.array([[0.5, 0.5, 0.5], [1.0, 1.0, 1.0]]))
        g.create_dataset("orientation", data=np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]]))
        g.create_dataset("shape", data=np.array(["sphere:d=1", "cylinder:d=1,l=1"], dtype=object),
                         dtype=h5py.string_dtype())
    write(os.path.join(out, "good.h5"), ind, mask, spacing=(0.25, 0.2, 0.2),
          origin=(1.0, -0.9, -0.8), extra=particles)
    write(os.path.join(out, "no_indicator.h5"), None)
    write(os.path.join(out, "float_indicator.h5"), ind.astype(np.float32))
    write(os.path.join(out, "rank2_indicator.h5"), ind[0])
    bad = ind.copy()
    bad[3, 3, 3] = 2
    write(os.path.join(out, "values.h5"), bad)
    write(os.path.join(out, "mask_shape.h5"), ind, mask[:, :, :-1])
    write(os.path.join(out, "spacing_zero.h5"), ind, spacing=(0.2, 0.0, 0.2))
    write(os.path.join(out, "spacing_nan.h5"), ind, spacing=(0.2, float("nan"), 0.2))
    write(os.path.join(out, "wrong_format.h5"), ind, fmt="something-else")
    # h5py's own lzf filter, which libhdf5 cannot decode.
    with h5py.File(os.path.join(out, "lzf.h5"), "w") as f:
        f.attrs["format"] = "voxpack-bed"
        f.attrs["format_version"] = 1
        f.attrs["spacing_mm"] = np.full(3, 0.2)
        f.attrs["origin_mm"] = np.zeros(3)
        f.create_dataset("indicator", data=ind, chunks=(4, 5, 9), compression="lzf")
    # Shuffle + gzip in odd chunks: decoded by voxpack itself, exact porosity.
    write(os.path.join(out, "shuffle_gzip.h5"), None, extra=lambda f: f.create_dataset(
        "indicator", data=ind, chunks=(5, 3, 4), compression="gzip", shuffle=True))
    # A truncated file: the first half of a valid one.
    data = open(os.path.join(out, "good.h5"), "rb").read()
    with open(os.path.join(out, "truncated.h5"), "wb") as f:
        f.write(data[: len(data) // 2])
    with open(os.path.join(out, "text.h5"), "w") as f:
        f.write("this is a text file, not HDF5\n")
    sel = mask.astype(bool)
    print(repr(float(ind[sel].sum()) / float(sel.sum())))
    print(repr(float(ind.sum()) / float(ind.size)))


if __name__ == "__main__":
    main(sys.argv[1])
