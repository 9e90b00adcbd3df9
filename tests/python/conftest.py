"""Fixtures of the voxpack pytest suite: the CLI binary, the checkout, small beds.

ctest sets PYTHONPATH (the build's python/ folder), VOXPACK_BIN and VOXPACK_SOURCE_DIR
(tests/python/CMakeLists.txt); run by hand:
  PYTHONPATH=build/python VOXPACK_BIN=build/bin/voxpack /usr/bin/python3 -m pytest tests/python
"""

import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

SOURCE = pathlib.Path(os.environ.get("VOXPACK_SOURCE_DIR",
                                     pathlib.Path(__file__).resolve().parents[2]))


@pytest.fixture(scope="session")
def source_dir():
    return SOURCE


@pytest.fixture(scope="session")
def voxpack_bin():
    path = os.environ.get("VOXPACK_BIN", str(SOURCE / "build" / "bin" / "voxpack"))
    if not os.path.exists(path):
        pytest.fail(f"voxpack binary not found at {path} (set VOXPACK_BIN)")
    return path


@pytest.fixture(scope="session")
def cli(voxpack_bin):
    """Runs the voxpack binary; returns the CompletedProcess (text)."""
    def run(*args, check=True):
        p = subprocess.run([voxpack_bin, "--quiet", *map(str, args)], capture_output=True,
                           text=True)
        if check and p.returncode != 0:
            raise AssertionError(f"voxpack {' '.join(map(str, args))} exited {p.returncode}: "
                                 f"{p.stderr}")
        return p
    return run


def sphere_bed(shape=(24, 20, 22), radius=3.2, seed=0):
    """A small synthetic bed: non-overlapping balls (solid) in a cylinder mask, with labels."""
    rng = np.random.default_rng(seed)
    nz, ny, nx = shape
    z, y, x = np.indices(shape, dtype=float)
    indicator = np.ones(shape, dtype=bool)      # True = void
    labels = np.zeros(shape, dtype=np.uint32)
    centres = []
    for _ in range(200):
        c = rng.uniform([radius, radius, radius], [nz - radius, ny - radius, nx - radius])
        if all(np.linalg.norm(c - d) > 2 * radius for d in centres):
            centres.append(c)
            ball = (z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2 <= radius ** 2
            indicator[ball] = False
            labels[ball] = len(centres)
    cy, cx = (ny - 1) / 2, (nx - 1) / 2
    mask = ((y - cy) ** 2 + (x - cx) ** 2 <= (min(ny, nx) / 2) ** 2)
    return indicator, mask, labels, np.array([c[::-1] for c in centres])


@pytest.fixture(scope="session")
def small_bed_file(tmp_path_factory):
    """A bed file written by hand with h5py (docs/FORMATS.md), with mask, labels and a
    particle table, spacing 0.5 mm."""
    import h5py
    indicator, mask, labels, centres = sphere_bed()
    path = tmp_path_factory.mktemp("beds") / "spheres.h5"
    spacing = 0.5
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "voxpack-bed"
        f.attrs["format_version"] = 1
        f.attrs["spacing_mm"] = np.array([spacing] * 3)
        f.attrs["origin_mm"] = np.array([0.25, -4.75, -5.25])
        f.attrs["provenance"] = json.dumps({"command": "tests/python/conftest.py"})
        f.create_dataset("indicator", data=indicator.astype(np.uint8), chunks=True,
                         compression="gzip")
        f.create_dataset("mask", data=mask.astype(np.uint8), chunks=True, compression="gzip")
        f.create_dataset("labels", data=labels, chunks=True, compression="gzip")
        n = len(centres)
        f.create_dataset("particles/position_mm", data=centres * spacing)
        q = np.zeros((n, 4))
        q[:, 0] = 1
        f.create_dataset("particles/orientation", data=q)
        f.create_dataset("particles/shape", data=[f"sphere:d={2 * 3.2 * spacing}"] * n,
                         dtype=h5py.string_dtype())
    return path
