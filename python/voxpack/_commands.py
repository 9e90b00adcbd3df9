"""pack, stats, ingest, phantom, compare: thin wrappers over the C++ commands.

Every function runs the command the CLI runs (`voxpack._voxpack.run_cli`, the same
parsing and code as the binary) on temporary files and reads the result back, except
`stats` of an in-memory bed, which calls the statistics library directly (the function
`voxpack stats` calls) so no file is written.
"""

from __future__ import annotations

import json
import os
import sys
import tomllib
from typing import Any, Callable, Mapping, Optional, Sequence, Union

import numpy as np

from . import _voxpack
from ._bed import Bed, PathLike, as_bed, read_bed, write_bed
from ._run import flags, global_args, progress_adapter, read_nrrd, run_cli, scratch, toml_dumps, write_nrrd, _message

_SCENE_KEYS = ("mode", "shape", "container", "voxel_size_mm", "target_volume_error", "count",
               "fill_height_mm", "seed", "supersample")


def pack(mode: Optional[str] = None, shape: Union[str, Sequence, None] = None,
         container: Optional[str] = None, voxel_size_mm: Optional[float] = None,
         count: Optional[int] = None, seed: Optional[int] = None, *,
         fill_height_mm: Optional[float] = None, target_volume_error: Optional[float] = None,
         supersample: Optional[int] = None, scene: Union[Mapping, PathLike, None] = None,
         output: Optional[PathLike] = None, threads: Optional[int] = None,
         memory_limit: Optional[str] = None, progress: Optional[Callable] = None,
         **mode_options) -> Bed:
    """Packs a bed (`voxpack pack`) and returns it as a Bed.

    Takes the keys of the TOML scene file (docs/scene.md); lengths in mm, times in s.
    The scene is written as TOML and run by the CLI's own `pack` command, so the bed is
    byte for byte the CLI's for the same scene and seed.

    Parameters (scene keys)
    -----------------------
    mode : "mc" | "dem"
        Monte Carlo (docs/mc.md) or digital DEM (docs/dem.md). Required.
    shape : str or list
        Shape SPEC, e.g. "cylinder:d=5.4,l=3.8" (mm); a list mixes shapes by number
        fraction: ["sphere:d=3@0.7", "sphere:d=2@0.3"] or [{"spec": ..., "fraction": ...}].
    container : str
        Container SPEC, e.g. "cylinder:d=43.3,h=60" (mm), "box:x=40,y=40,z=60".
    voxel_size_mm : float
        Lattice spacing, mm (> 0); or instead `target_volume_error`: the coarsest voxel whose
        mean digitisation volume error is below this fraction (0..1).
    count : int
        Particles to pack (>= 1); or instead `fill_height_mm`: pack up to this height, mm.
    seed : int
        Random seed (>= 0). Same seed -> same bed, for any thread count.
    supersample : int
        Digitisation samples per voxel axis, 1..8 (default 1).
    scene : dict or path
        A scene dict or a TOML scene file; the keyword arguments above win over it (as
        flags win over the file; giving count or fill_height_mm replaces both).
    **mode_options
        Keys of the mode's table, e.g. ``rebound_probability=0.2`` for mc, or
        ``friction=0.3, tap_cycles=10`` for dem (also ``mc={...}`` / ``dem={...}``).

        mc (docs/mc.md): rebound_probability 0..1 (0.1), rotation_probability 0..1
        (0.05), max_rotation_deg degrees (15), max_sweeps (20000), settle_sweeps
        (0 = auto), settle_tolerance (0.001), settle_max_fall_diameters (0.25),
        inject_attempts (200), tap_cycles (0), tap_rebound_probability (0.5), tap_sweeps (0).

        dem (docs/dem.md): friction mu >= 0 (0.5), restitution 0..1 (0.5), tap_cycles (0),
        density_g_cm3 g/cm^3 (1.5), stiffness_n_mm3 N/mm^3 (0 = auto), target_overlap
        (0.004), contact_stiffness_cap (1), time_step_s s (0 = auto), time_step_fraction
        (1/20), tap_amplitude_mm mm (0 = 0.3 d), tap_frequency_hz Hz (30), tap_rest_s s
        (0.1), sleep_time_s s (0.01), settle_kinetic (1e-6), settle_velocity (1e-3),
        max_time_s s (20), rain_height_d diameters (4), rain_volume_fraction (0.3),
        rain_speed_mm_s mm/s (0), contact "levelset" | "voxel", sleeping True/False.

    Run options
    -----------
    output : path, optional
        Also keep the bed file here (otherwise a temporary file, removed).
    threads : int, optional
        Worker threads (`--threads`, 0 = all cores; default all).
    memory_limit : str, optional
        Memory budget, e.g. "2G" (`--memory-limit`).
    progress : callable, optional
        progress(done, total) with done/total the fraction of the current stage
        (progress(done, total, stage) if it takes three arguments). Called with the GIL.

    Returns a Bed (indicator, mask, labels, particles, provenance incl. the run status).
    Ctrl-C (KeyboardInterrupt) stops the run; the partial bed is dropped. Bad scenes
    raise ValueError with the CLI's message; files that cannot be read raise OSError.
    """
    doc: dict = {}
    if scene is not None:
        if isinstance(scene, Mapping):
            doc = {k: (dict(v) if isinstance(v, Mapping) else v) for k, v in scene.items()}
        else:
            with open(os.fspath(scene), "rb") as f:
                try:
                    doc = tomllib.load(f)
                except tomllib.TOMLDecodeError as e:
                    raise ValueError(f"{os.fspath(scene)}: {e}") from None
    given = {"mode": mode, "shape": shape, "container": container,
             "voxel_size_mm": voxel_size_mm, "target_volume_error": target_volume_error,
             "count": count, "fill_height_mm": fill_height_mm, "seed": seed,
             "supersample": supersample}
    given = {k: v for k, v in given.items() if v is not None}
    # As on the command line: either goal key replaces both, either voxel key both.
    for pair in (("count", "fill_height_mm"), ("voxel_size_mm", "target_volume_error")):
        if any(k in given for k in pair):
            for k in pair:
                doc.pop(k, None)
    doc.pop("output", None)  # the bed comes back as the return value (output= keeps a file)
    doc.update(given)
    for table in ("mc", "dem"):
        if table in mode_options:
            t = mode_options.pop(table)
            if not isinstance(t, Mapping):
                raise ValueError(f"{table}=: expected a dict of [{table}] options")
            doc.setdefault(table, {}).update(t)
    if mode_options:
        m = doc.get("mode")
        if m not in ("mc", "dem"):
            raise ValueError("mode= is required (mc or dem) to place the options "
                             + ", ".join(sorted(mode_options)))
        doc.setdefault(m, {}).update(mode_options)
    with scratch() as tmp:
        scene_file = os.path.join(tmp, "scene.toml")
        with open(scene_file, "w", encoding="utf-8") as f:
            f.write(toml_dumps(doc))
        out = os.fspath(output) if output is not None else os.path.join(tmp, "bed.h5")
        run_cli(global_args(threads, memory_limit) + ["pack", "--config", scene_file, "-o", out],
                progress, hide=(scene_file,))
        return read_bed(out)


def _roi_text(roi) -> Optional[str]:
    if roi is None or isinstance(roi, str):
        return roi
    lo, hi = roi
    return f"{float(lo)!r}:{float(hi)!r}"


def stats(bed_or_array, only: Optional[Sequence[str]] = None, *, spacing_mm=None,
          origin_mm=None, mask=None, labels=None, particle_diameter_mm: Optional[float] = None,
          trim_mm: Optional[float] = None, s2_max_lag_mm: Optional[float] = None,
          s2_float: bool = False, radial_bin_mm: Optional[float] = None,
          mes_method: Optional[str] = None, mes_samples: Optional[int] = None,
          mes_directions: Optional[int] = None, seed: Optional[int] = None,
          roi_mm=None, roi_box_mm=None, packed_region: str = "off", bed_window: bool = False,
          threads: Optional[int] = None, progress: Optional[Callable] = None) -> dict:
    """Structure statistics (`voxpack stats`), the same dict as the CLI's JSON.

    The statistics library's computeStats runs on the bed in memory (GIL released), the
    function `voxpack stats` calls, and the same keys are added (roi_mm, input,
    command_line, input_provenance), so the dict equals the CLI JSON value for value
    (`input` is the path, or None for an array; `command_line` says it came from Python).

    Parameters
    ----------
    bed_or_array : Bed, numpy array or path
        A Bed, a bed file, or a 3-D indicator array: bool with True = void (PoreSpy's
        convention) or 0/1 integers with 1 = void; any memory layout (C, Fortran, views);
        copied once into the C++ grid.
    only : list of str, optional
        Statistics to compute (default all): axial, radial, s2, mes, psd, chords, shadow,
        coordination, orientation (`voxpack.statistic_names()`).
    spacing_mm, origin_mm : float or 3 floats (z, y, x), mm
        Lattice of an array (default spacing 1 mm, origin 0); override a Bed's.
    mask, labels : arrays, optional
        Container/ROI mask (1 = inside) and particle labels for an array input.
    particle_diameter_mm : float
        Particle diameter, mm, for end trimming and wall distances (default: from the
        particle table, else unknown).
    trim_mm : float
        mm trimmed at each bed end for the axial statistics (default 2 d when known).
    s2_max_lag_mm : float
        Largest S2 lag, mm (default a quarter of the smallest extent, <= 64 voxels).
    s2_float : bool
        S2 FFTs in single precision (faster, less exact).
    radial_bin_mm : float
        Radial annulus width, mm (default one voxel).
    mes_method : "lattice" | "isotropic" | "both"
        Mean empty space method (default lattice); mes_samples (20000) and
        mes_directions (64) for the isotropic path; seed (1) of its sampling.
    roi_mm : (z0, z1) or "Z0:Z1"
        Crop to voxel centres with z in [z0, z1] mm first (`--roi-mm`).
    roi_box_mm : str "X0:X1,Y0:Y1,Z0:Z1" or ((x0, x1) | None, (y0, y1) | None, (z0, z1) | None)
        Crop to a box in mm first (`--roi-box-mm`).
    packed_region : "off" | "auto"
        auto: every statistic on the packed slices only (detected as compare does: partly
        solid slices denser than half the densest); off (default): the whole bed, with a
        warning on the "voxpack" logger when > 10 % of the mask is headspace. The dict's
        `packed_region` record says what was found and whether it was applied
        (`--packed-region`).
    bed_window : bool
        Crop to the bed's interior first: from 2 d above the lowest mask slice to 2 d below
        the highest particle centre (needs particle_diameter_mm and a particle table; not
        with roi_mm / roi_box_mm / packed_region="auto"; `--bed-window`).
    threads : int
        Worker threads (default all cores, as `--threads 0`).
    progress : callable
        progress(done, total) as in pack(); Ctrl-C stops the run (KeyboardInterrupt).
    """
    path = os.fspath(bed_or_array) if isinstance(bed_or_array, (str, os.PathLike)) else None
    overrides = any(v is not None for v in (spacing_mm, origin_mm, mask, labels))
    # A path without overrides is read by C++ straight into its grids (no numpy copy).
    bed = None if path is not None and not overrides else as_bed(
        bed_or_array, spacing_mm=spacing_mm, origin_mm=origin_mm, mask=mask, labels=labels)
    if isinstance(only, str):
        only = [s for s in only.split(",")]
    if roi_box_mm is not None and not isinstance(roi_box_mm, str):
        roi_box_mm = ",".join("" if r is None else _roi_text(r) for r in roi_box_mm)
    options = {
        "only": None if only is None else list(only),
        "particle_diameter_mm": particle_diameter_mm, "trim_mm": trim_mm,
        "s2_max_lag_mm": s2_max_lag_mm, "s2_float": bool(s2_float),
        "radial_bin_mm": radial_bin_mm, "mes_method": mes_method, "mes_samples": mes_samples,
        "mes_directions": mes_directions, "seed": seed, "threads": threads,
        "roi_mm": _roi_text(roi_mm), "roi_box_mm": roi_box_mm,
        "packed_region": packed_region, "bed_window": bool(bed_window),
        "input": path, "command_line": "python: voxpack.stats",
    }
    return _voxpack.stats(path if bed is None else bed._as_dict(), options,
                          progress_adapter(progress), _message)


def ingest(path_or_array, output: Optional[PathLike] = None, *, spacing_mm=None,
           origin_mm=None, void: Optional[str] = None, threshold=None, column=None,
           resample_mm: Optional[float] = None, voxel_size_mm: Optional[float] = None,
           labels: bool = False, threads: Optional[int] = None,
           memory_limit: Optional[str] = None, progress: Optional[Callable] = None,
           **options) -> Bed:
    """Segments an imaged volume into a bed (`voxpack ingest`), returned as a Bed.

    Parameters
    ----------
    path_or_array : path or numpy array
        An image file or folder the CLI reads (NRRD, MHA/MHD, NIfTI, TIFF stack folder,
        DICOM series folder, Bruker 2dseq), or a 3-D grey array [z][y][x] (written to a
        temporary NRRD with spacing_mm / origin_mm, (z, y, x) mm, default 1 / 0).
    output : path, optional
        Also keep the bed file here.
    void : "auto" | "bright" | "dark"
        Void phase: bright (MRI water), dark (XMT air), auto (phantom header, else dark).
    threshold : "otsu" | "kmeans" | number
        Segmentation threshold (default otsu).
    column : "auto" | "none" | (cx, cy, r) mm
        Column mask: detected, none, or a vertical cylinder axis (x, y) and radius.
    resample_mm : float
        Resample onto this isotropic voxel, mm (`--resample`).
    voxel_size_mm : float
        Isotropic voxel size, mm, overriding the file's spacing (`--voxel-size`).
    labels : bool
        Also write /labels (distance map + watershed particle labels).
    **options
        Other `voxpack ingest` flags by name, e.g. denoise="median" (none, median,
        median-box, curvature), median_radius (1..5 voxels), diffusion_iterations (1..100),
        diffusion_conductance (> 0), bias_correction="n4", n4_shrink (1..16),
        max_speck_voxels, max_hole_voxels, marker_depth (voxels).
    threads, memory_limit, progress : as in pack().
    """
    if isinstance(column, (tuple, list, np.ndarray)):
        column = ",".join(repr(float(c)) for c in column)
    if threshold is not None and not isinstance(threshold, str):
        threshold = repr(float(threshold))
    opts = {"void": void, "threshold": threshold, "column": column, "resample": resample_mm,
            "voxel_size": voxel_size_mm, "labels": bool(labels)}
    opts.update(options)
    with scratch() as tmp:
        if isinstance(path_or_array, (str, os.PathLike)):
            src = os.fspath(path_or_array)
        else:
            src = os.path.join(tmp, "image.nrrd")
            write_nrrd(src, path_or_array,
                       (1.0, 1.0, 1.0) if spacing_mm is None else _zyx(spacing_mm),
                       (0.0, 0.0, 0.0) if origin_mm is None else _zyx(origin_mm))
        out = os.fspath(output) if output is not None else os.path.join(tmp, "bed.h5")
        run_cli(global_args(threads, memory_limit) + ["ingest", src, "-o", out] + flags(opts, {}),
                progress, hide=(tmp,))
        return read_bed(out)


def _zyx(v) -> tuple:
    if np.isscalar(v):
        return (float(v),) * 3
    return tuple(float(x) for x in v)


class Image:
    """A grey image: ``array`` [z][y][x], ``spacing_mm`` and ``origin_mm`` (z, y, x) mm."""

    def __init__(self, array: np.ndarray, spacing_mm, origin_mm):
        self.array = array
        self.spacing_mm = tuple(spacing_mm)
        self.origin_mm = tuple(origin_mm)

    def __repr__(self) -> str:
        return f"Image(shape={self.array.shape}, dtype={self.array.dtype}, spacing_mm={self.spacing_mm})"


def phantom(bed, output: Optional[PathLike] = None, *, modality: str = "mri", snr: float = 10.0,
            seed: int = 1, blur_mm: Optional[float] = None, bias: Optional[float] = None,
            voxel_size_mm: Optional[float] = None, wall_mm: Optional[float] = None,
            pixel_type: Optional[str] = None, threads: Optional[int] = None,
            memory_limit: Optional[str] = None, progress: Optional[Callable] = None):
    """Simulates an MRI or XMT image of a known bed (`voxpack phantom`).

    Parameters
    ----------
    bed : Bed, array or path
        The bed imaged (an array is an indicator, True/1 = void, spacing 1 mm).
    output : path, optional
        Image file to write (format by extension: .nrrd, .mha, .nii.gz, .tif); the
        function then returns the path. Without it, returns an Image (array, spacing_mm,
        origin_mm) read from a temporary NRRD.
    modality : "mri" | "xmt"
        MRI: water bright, Rician noise; XMT: solid bright, Gaussian noise.
    snr : float
        Phase contrast / noise sigma (> 0).
    seed : int
        Noise and bias seed.
    blur_mm : float
        Gaussian blur sigma, mm (>= 0).
    bias : float
        Bias field amplitude F: gain in [1-F, 1+F], 0..1.
    voxel_size_mm : float
        Output voxel size, mm (default the bed's).
    wall_mm : float
        Container wall thickness drawn outside the mask, mm (default 4 voxels).
    pixel_type : "float32" | "uint16" | "uint8"
    threads, memory_limit, progress : as in pack().
    """
    opts = {"modality": modality, "snr": snr, "seed": seed, "blur_mm": blur_mm, "bias": bias,
            "voxel_size": voxel_size_mm, "wall_mm": wall_mm, "pixel_type": pixel_type}
    with scratch() as tmp:
        src = _bed_file(bed, tmp, "bed")
        out = os.fspath(output) if output is not None else os.path.join(tmp, "image.nrrd")
        run_cli(global_args(threads, memory_limit) + ["phantom", src, "-o", out] + flags(opts, {}),
                progress, hide=(tmp,))
        if output is not None:
            return out
        a, spacing, origin = read_nrrd(out)
        return Image(a.copy(), spacing, origin)


def _bed_file(bed, tmp: str, name: str) -> str:
    if isinstance(bed, (str, os.PathLike)):
        return os.fspath(bed)
    path = os.path.join(tmp, name + ".h5")
    write_bed(path, bed)
    return path


def compare(reference, candidates, out_dir: Optional[PathLike] = None, *,
            particle_diameter_mm: Optional[float] = None, trim_mm: Optional[float] = None,
            s2_max_lag_mm: Optional[float] = None, radial_step_mm: Optional[float] = None,
            s2_step_mm: Optional[float] = None, bed_fraction: Optional[float] = None,
            figures: bool = True, flow: bool = False, flow_tolerance: Optional[float] = None,
            flow_max_steps: Optional[int] = None, flow_walls: Optional[str] = None,
            threads: Optional[int] = None, memory_limit: Optional[str] = None,
            progress: Optional[Callable] = None) -> dict:
    """Compares candidate beds with a reference bed (`voxpack compare`).

    Parameters
    ----------
    reference : Bed, array or path
        The reference (e.g. an ingested image).
    candidates : list of Bed/array/path, or dict name -> Bed/array/path
        The beds compared with it; dict keys name them in the summary and report (Beds
        without a name are "candidate1", ...; files keep their file name).
    out_dir : path, optional
        Report folder to keep (summary.json, index.html, CSV, figures). Without it the
        report is made in a temporary folder and only the summary is returned.
    particle_diameter_mm : float
        Particle diameter, mm, for end trimming and wall distances (default inferred).
    trim_mm : float
        mm trimmed at each bed end for the axial statistics (default 2 d).
    s2_max_lag_mm : float
        Largest S2 lag, mm.
    radial_step_mm, s2_step_mm : float
        Steps of the common wall-distance / S2 lag grids, mm (default the coarser bed's).
    bed_fraction : float
        Packed region: slices denser than this fraction of the densest (default 0.5).
    figures : bool
        Draw the report figures (matplotlib); False = numbers and CSV only.
    flow : bool
        Also run the flow solver on every bed's packed region (`--flow`): permeability,
        tortuosity and wall-flow share against the reference (summary "flow").
    flow_tolerance, flow_max_steps : float, int
        The flow solver's stopping rule (defaults 1e-5 and 200000).
    flow_walls : "halfway" | "interpolated"
        Walls of the flow solver (default halfway; interpolated cuts the links at the exact
        surfaces of each bed's particle table and container).
    threads, memory_limit, progress : as in pack().

    Returns the summary dict (DIR/summary.json): reference, candidates with density_mean,
    density_std, density_rel_diff, axial_ks_p, radial_rmse, s2_rmse, mes_ks.
    """
    if isinstance(candidates, Mapping):
        items = list(candidates.items())
    else:
        if isinstance(candidates, (str, os.PathLike, Bed, np.ndarray)):
            candidates = [candidates]
        items = [(None, c) for c in candidates]
    opts = {"particle_diameter": particle_diameter_mm, "trim_mm": trim_mm,
            "s2_max_lag_mm": s2_max_lag_mm, "radial_step_mm": radial_step_mm,
            "s2_step_mm": s2_step_mm, "bed_fraction": bed_fraction, "no_figures": not figures,
            "flow": bool(flow), "flow_tolerance": flow_tolerance,
            "flow_max_steps": flow_max_steps, "flow_walls": flow_walls}
    if not flow and (flow_tolerance is not None or flow_max_steps is not None
                     or flow_walls is not None):
        raise ValueError("flow_tolerance, flow_max_steps and flow_walls need flow=True")
    with scratch() as tmp:
        beds = os.path.join(tmp, "beds")
        os.mkdir(beds)
        ref = _named_file(reference, beds, "reference")
        cands = [_named_file(c, beds, name or f"candidate{n + 1}") for n, (name, c) in enumerate(items)]
        out = os.fspath(out_dir) if out_dir is not None else os.path.join(tmp, "report")
        args = global_args(threads, memory_limit) + ["compare", "--reference", ref] + cands
        args += ["-o", out, "--python", sys.executable] + flags(opts, {})
        run_cli(args, progress, hide=(tmp,))
        with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
            return json.load(f)


def _named_file(bed, folder: str, name: str) -> str:
    if isinstance(bed, (str, os.PathLike)):
        src = os.fspath(bed)
        if name.startswith("candidate") or name == "reference":
            return src
        # A named file: link it under that name so the report uses the name.
        dst = os.path.join(folder, name + ".h5")
        os.symlink(os.path.abspath(src), dst)
        return dst
    return _bed_file(bed, folder, name)


def statistic_names() -> list:
    """Names accepted by stats(only=...)."""
    return list(_voxpack.statistic_names())
