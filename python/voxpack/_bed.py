"""The Bed type and the bed file (docs/FORMATS.md), over core's readBed/writeBed."""

from __future__ import annotations

import math
import os
from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np

from . import _voxpack

PathLike = Union[str, "os.PathLike[str]"]

_PARTICLE_KEYS = ("position_mm", "orientation", "shape")


def _triple(value, what: str, positive: bool) -> tuple:
    """(z, y, x) from a number or three numbers; checked finite (and > 0)."""
    if np.isscalar(value):
        value = (value, value, value)
    try:
        t = tuple(float(v) for v in value)
    except TypeError:
        raise ValueError(f"{what}: expected a number or 3 numbers (z, y, x), got {value!r}") from None
    if len(t) != 3:
        raise ValueError(f"{what}: expected 3 numbers (z, y, x), got {len(t)}")
    for v in t:
        if not math.isfinite(v) or (positive and v <= 0):
            raise ValueError(f"{what}: each value must be finite{' and > 0' if positive else ''}, got {t}")
    return t


def _check_3d(a: np.ndarray, what: str) -> None:
    if a.ndim != 3:
        raise ValueError(f"{what}: expected a 3-D array [z][y][x], got {a.ndim} dimension(s), "
                         f"shape {a.shape}")
    if 0 in a.shape:
        raise ValueError(f"{what}: the array is empty (shape {a.shape})")


def as_binary(array, what: str = "indicator") -> np.ndarray:
    """A 3-D uint8 0/1 array (1 = void for an indicator) from any 3-D array.

    bool (True = void, PoreSpy's convention) becomes a zero-copy uint8 view; uint8 is kept
    as it is (any strides); other integer dtypes must hold only 0 and 1 and are converted
    (one copy). Floats and anything else raise ValueError.
    """
    a = np.asarray(array)
    _check_3d(a, what)
    if a.dtype == np.bool_:
        return a.view(np.uint8)
    if a.dtype == np.uint8:
        return a
    if a.dtype.kind in "iu":
        if a.size and (a.min() < 0 or a.max() > 1):
            raise ValueError(f"{what}: an integer array must hold only 0 and 1 "
                             f"(found values in [{a.min()}, {a.max()}])")
        return a.astype(np.uint8)
    raise ValueError(f"{what}: dtype {a.dtype} is not accepted; give a bool array (True = void) "
                     f"or a 0/1 integer array (threshold a grey image first, e.g. image > t)")


def as_labels(array, what: str = "labels") -> np.ndarray:
    """A 3-D uint32 label array (0 = none) from any 3-D integer array (copy unless uint32)."""
    a = np.asarray(array)
    _check_3d(a, what)
    if a.dtype == np.uint32:
        return a
    if a.dtype.kind in "iu" and a.dtype != np.bool_:
        if a.size and (a.min() < 0 or a.max() > np.iinfo(np.uint32).max):
            raise ValueError(f"{what}: labels must lie in 0..2^32-1")
        return a.astype(np.uint32)
    raise ValueError(f"{what}: dtype {a.dtype} is not accepted; labels are integers (0 = none)")


def _as_particles(particles: Optional[Mapping[str, Any]]) -> dict:
    if not particles:
        return {}
    unknown = set(particles) - set(_PARTICLE_KEYS)
    if unknown:
        raise ValueError(f"particles: unknown key(s) {sorted(unknown)} (known: {list(_PARTICLE_KEYS)})")
    out = {}
    for key, cols in (("position_mm", 3), ("orientation", 4)):
        if key in particles and particles[key] is not None:
            a = np.ascontiguousarray(particles[key], dtype=np.float64)
            if a.ndim != 2 or a.shape[1] != cols:
                raise ValueError(f"particles['{key}']: expected shape [N,{cols}], got {a.shape}")
            out[key] = a
    if "shape" in particles and particles["shape"] is not None:
        out["shape"] = np.asarray([str(s) for s in particles["shape"]], dtype=str)
    return out


class Bed:
    """A packed or imaged bed on one voxel lattice (docs/FORMATS.md).

    Attributes
    ----------
    indicator : numpy.ndarray, uint8 [nz, ny, nx]
        I(x) of the paper: 1 = void, 0 = solid. C order [z][y][x], z is the column axis.
        A bool array is taken with True = void (PoreSpy's convention) as a zero-copy uint8
        view; uint8 arrays of any memory layout are kept without a copy.
    mask : numpy.ndarray uint8 [nz, ny, nx] or None
        1 = inside the container / region of interest; None = everything inside.
    labels : numpy.ndarray uint32 [nz, ny, nx] or None
        Particle id per voxel (id n is row n-1 of the particle table), 0 = none.
    spacing_mm : tuple of 3 floats
        Voxel size (z, y, x) in mm; a single number means isotropic. Default 1.
    origin_mm : tuple of 3 floats
        Centre of voxel [0, 0, 0], (z, y, x) in mm (ITK convention). Default 0.
    particles : dict of numpy arrays
        ``position_mm`` float64 [N, 3] (x, y, z), ``orientation`` float64 [N, 4] unit
        quaternions (w, x, y, z), ``shape`` str [N] shape SPECs; empty dict when absent.
    provenance : dict
        Version, command line, seed, options and run status of what made the bed.

    Arrays read from a file (read_bed, pack, ingest) own the C++ storage (no copy). When a
    bed goes to C++ (write_bed, stats) each volume is copied once into the core's grids.
    """

    def __init__(self, indicator, mask=None, labels=None, spacing_mm=1.0, origin_mm=0.0,
                 particles: Optional[Mapping[str, Any]] = None,
                 provenance: Optional[Mapping[str, Any]] = None):
        self.indicator = as_binary(indicator, "indicator")
        self.mask = None if mask is None else as_binary(mask, "mask")
        self.labels = None if labels is None else as_labels(labels, "labels")
        for name, a in (("mask", self.mask), ("labels", self.labels)):
            if a is not None and a.shape != self.indicator.shape:
                raise ValueError(f"{name}: shape {a.shape} differs from the indicator's "
                                 f"{self.indicator.shape}")
        self.spacing_mm = _triple(spacing_mm, "spacing_mm", positive=True)
        self.origin_mm = _triple(origin_mm, "origin_mm", positive=False)
        self.particles = _as_particles(particles)
        self.provenance = dict(provenance) if provenance else {}

    @property
    def shape(self) -> tuple:
        """(nz, ny, nx)."""
        return self.indicator.shape

    @property
    def porosity(self) -> float:
        """Void fraction inside the mask (as `voxpack info`); NaN when the mask is empty."""
        if self.mask is None:
            n = self.indicator.size
            void = int(np.count_nonzero(self.indicator))
        else:
            inside = self.mask.astype(bool)
            n = int(np.count_nonzero(inside))
            void = int(np.count_nonzero(self.indicator[inside]))
        return void / n if n else float("nan")

    @property
    def packing_density(self) -> float:
        """1 - porosity inside the mask."""
        return 1.0 - self.porosity

    def _as_dict(self) -> dict:
        return {"indicator": self.indicator, "mask": self.mask, "labels": self.labels,
                "spacing_mm": self.spacing_mm, "origin_mm": self.origin_mm,
                "particles": self.particles, "provenance": self.provenance}

    def __repr__(self) -> str:
        parts = [f"shape={self.shape}", f"spacing_mm={self.spacing_mm}"]
        if self.mask is not None:
            parts.append("mask")
        if self.labels is not None:
            parts.append("labels")
        if "position_mm" in self.particles:
            parts.append(f"{len(self.particles['position_mm'])} particles")
        return "Bed(" + ", ".join(parts) + ")"


def _from_dict(d: dict) -> Bed:
    return Bed(d["indicator"], d["mask"], d["labels"], d["spacing_mm"], d["origin_mm"],
               d["particles"], d["provenance"])


def as_bed(bed_or_array, spacing_mm=None, origin_mm=None, mask=None, labels=None) -> Bed:
    """A Bed from a Bed, a 3-D array or a bed file path; keyword arguments override."""
    if isinstance(bed_or_array, (str, os.PathLike)):
        bed = read_bed(bed_or_array)
    elif isinstance(bed_or_array, Bed):
        bed = bed_or_array
    else:
        return Bed(bed_or_array, mask=mask, labels=labels,
                   spacing_mm=1.0 if spacing_mm is None else spacing_mm,
                   origin_mm=0.0 if origin_mm is None else origin_mm)
    if spacing_mm is None and origin_mm is None and mask is None and labels is None:
        return bed
    return Bed(bed.indicator, bed.mask if mask is None else mask,
               bed.labels if labels is None else labels,
               bed.spacing_mm if spacing_mm is None else spacing_mm,
               bed.origin_mm if origin_mm is None else origin_mm, bed.particles, bed.provenance)


def read_bed(path: PathLike) -> Bed:
    """Reads a bed file (.h5, docs/FORMATS.md) into a Bed.

    The volumes are read by the same C++ reader as the CLI (validated the same way) and
    handed to numpy without a copy: each array owns the C++ storage.

    Raises OSError when the file cannot be opened or is not HDF5, ValueError
    (voxpack.FormatError) when it breaks the bed format, with the CLI's message.
    """
    return _from_dict(_voxpack.read_bed(os.fspath(path)))


def write_bed(path: PathLike, bed, *, spacing_mm=None, origin_mm=None, mask=None,
              compression_level: int = 4) -> None:
    """Writes a bed file atomically (temporary name, then rename), as every voxpack command.

    Parameters
    ----------
    path : str or path-like
        Output .h5 file.
    bed : Bed or numpy array
        A Bed, or a 3-D indicator array (bool: True = void; or 0/1 integers; 1 = void)
        of any memory layout. spacing_mm / origin_mm / mask apply to an array (and
        override a Bed's); spacing defaults to 1 mm.
    compression_level : int
        Deflate level 0..9 (default 4, as the CLI).

    The arrays are copied once into the C++ grids; the written file is read by every
    voxpack command (`voxpack info`, `stats`, ...).
    """
    b = as_bed(bed, spacing_mm=spacing_mm, origin_mm=origin_mm, mask=mask)
    _voxpack.write_bed(os.fspath(path), b._as_dict(), int(compression_level))


def bed_datasets(path: PathLike) -> list:
    """Names of the datasets in a bed file, e.g. ['/indicator', '/mask']."""
    return list(_voxpack.bed_datasets(os.fspath(path)))
