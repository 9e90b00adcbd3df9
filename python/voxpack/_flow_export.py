"""flow and export: the `voxpack flow` and `voxpack export` commands, run in-process.

Like pack/ingest/phantom/compare they go through the CLI's own parsing and code
(`voxpack._voxpack.run_cli`, i.e. app::runCommandLine), so the numbers and the bytes are the
binary's. An in-memory Bed is written to a temporary bed file first (the commands read
files); a path is handed to the command as it is.
"""

from __future__ import annotations

import json
import os
from typing import Callable, Optional

from ._bed import Bed, PathLike, write_bed
from ._run import flags, global_args, run_cli, scratch


def _is_path(x) -> bool:
    return isinstance(x, (str, os.PathLike))


def _roi_text(roi) -> Optional[str]:
    if roi is None or isinstance(roi, str):
        return roi
    lo, hi = roi
    return f"{float(lo)!r}:{float(hi)!r}"


def flow(bed, *, axis: str = "z", periodic: bool = False, mirror: bool = False,
         reservoir_layers: Optional[int] = None, tolerance: Optional[float] = None,
         max_steps: Optional[int] = None, check_interval: Optional[int] = None,
         tau: Optional[float] = None, double: bool = False, field: Optional[PathLike] = None,
         csv_dir: Optional[PathLike] = None, roi_mm=None, velocity_mm_s: Optional[float] = None,
         viscosity_pa_s: Optional[float] = None, density_kg_m3: Optional[float] = None,
         particle_diameter_mm: Optional[float] = None, walls: Optional[str] = None,
         mass_correction: bool = True, threads: Optional[int] = None,
         memory_limit: Optional[str] = None, progress: Optional[Callable] = None) -> dict:
    """Permeability, tortuosity and pressure drop by lattice Boltzmann (`voxpack flow`).

    Runs the CLI's `flow` command in this process (GIL released) and returns its FLOW.json
    as a dict (docs/flow.md): the same keys and values as `voxpack flow BED -o FLOW.json`
    on the same bed, except the run's own records `input` (the path given, or None for an
    in-memory bed), `command_line` ("python: voxpack.flow") and the timings (`wall_s`,
    `solver_wall_s`, `mlups`).

    Parameters
    ----------
    bed : Bed, numpy array or path
        The bed (void inside the mask is fluid). An array is an indicator (bool: True = void,
        or 0/1 with 1 = void) at spacing 1 mm; voxels must be cubic.
    axis : "z" | "y" | "x"
        Flow axis (default z, the column axis).
    periodic : bool
        Every axis periodic (unit cells, periodic samples). Default: walls across the flow
        and fluid reservoirs along it.
    mirror : bool
        Close the ends with the mirrored sample instead of reservoirs (excludes periodic).
    reservoir_layers : int
        Fluid layers before and after the sample (default: 0.6 particle diameters, at
        least 4; else >= 2).
    tolerance : float
        Stop when the mean velocity changes by less than this (relative) per check
        (default 1e-5).
    max_steps : int
        Stop after this many time steps at the latest (default 200000).
    check_interval : int
        Time steps between convergence checks (default 100, >= 1).
    tau : float
        TRT symmetric relaxation time, > 0.5 (default 1.0; k does not depend on it).
    double : bool
        Store the populations in float64 (default float32 deviations).
    field : path, optional
        Also write velocity (mm/s) and pressure (Pa) to this HDF5 bed file (+ .xdmf beside).
    csv_dir : path, optional
        Also write radial_profile.csv and convergence.csv into this folder.
    roi_mm : (z0, z1) or "Z0:Z1"
        Only the layers whose centre z lies in [z0, z1] mm.
    velocity_mm_s : float
        Superficial velocity for the pressure gradients, mm/s (default 1).
    viscosity_pa_s : float
        Fluid dynamic viscosity, Pa s (default 1e-3, water at 20 C).
    density_kg_m3 : float
        Fluid density, kg/m^3 (default 998).
    particle_diameter_mm : float
        d for the correlations, mm (default: the spheres' d from the particle table, else
        the Sauter diameter 6(1-eps)/S_v).
    walls : "halfway" | "interpolated"
        halfway (default): bounce-back on the voxels; interpolated: links cut at the exact
        surfaces of the particle table and the container (keep tau <= 1).
    mass_correction : bool
        Interpolated walls: restore the initial mass at every check (default True; the
        interpolation leaks mass, and the mass put back is `mass_correction_relative`).
    threads, memory_limit, progress : as in pack(). Ctrl-C (KeyboardInterrupt) stops the
        run; nothing is returned and no file is left.

    Returns the FLOW.json dict: permeability_mm2, permeability_darcy, porosity,
    superficial_velocity, interstitial_velocity, tortuosity_hydraulic, reynolds, steps,
    converged, status ("converged", "not_converged" or "blocked"), residual,
    radial_profile, wall_flow_share, specific_surface_mm_inv, pressure_gradient (Pa/m), ...
    Bad options or beds raise ValueError with the CLI's message.
    """
    if axis not in ("z", "y", "x"):
        raise ValueError(f"axis: expected 'z', 'y' or 'x', got {axis!r}")
    if walls not in (None, "halfway", "interpolated"):
        raise ValueError(f"walls: expected 'halfway' or 'interpolated', got {walls!r}")
    opts = {"axis": axis, "periodic": bool(periodic), "mirror": bool(mirror),
            "reservoir_layers": reservoir_layers, "tolerance": tolerance,
            "max_steps": max_steps, "check_interval": check_interval, "tau": tau,
            "double": bool(double), "field": field, "csv": csv_dir, "roi_mm": _roi_text(roi_mm),
            "velocity_mm_s": velocity_mm_s, "viscosity_pa_s": viscosity_pa_s,
            "density_kg_m3": density_kg_m3, "particle_diameter_mm": particle_diameter_mm,
            "walls": walls, "no_mass_correction": not mass_correction}
    with scratch() as tmp:
        if _is_path(bed):
            src, given = os.fspath(bed), os.fspath(bed)
        else:
            bed = bed if isinstance(bed, Bed) else Bed(bed)
            src, given = os.path.join(tmp, "bed.h5"), None
            write_bed(src, bed)
        out = os.path.join(tmp, "flow.json")
        run_cli(global_args(threads, memory_limit) + ["flow", src, "-o", out] + flags(opts, {}),
                progress, hide=(tmp,))
        with open(out, encoding="utf-8") as f:
            result = json.load(f)
    result["input"] = given
    result["command_line"] = "python: voxpack.flow"
    if given is None:  # the bed's own provenance, not the one write_bed stamped on the copy
        result["input_provenance"] = json.loads(json.dumps(bed.provenance))
    return result


_FORMATS = ("stl", "obj", "xdmf", "vtkhdf", "vtk", "tiff", "nrrd", "mha", "csv")


def export(bed, format: str, output: Optional[PathLike] = None, *,
           contacts: Optional[str] = None, contact_size: Optional[float] = None,
           contact_tolerance_mm: Optional[float] = None, tolerance_mm: Optional[float] = None,
           wall: bool = True, surface: bool = False, smoothing_voxels: Optional[float] = None,
           taubin_iterations: Optional[int] = None, link: bool = False,
           threads: Optional[int] = None, memory_limit: Optional[str] = None,
           progress: Optional[Callable] = None) -> dict:
    """Writes a bed for CFD meshers, ParaView, Fiji, ITK tools or spreadsheets
    (`voxpack export`, docs/export.md).

    Runs the CLI's `export` command in this process (GIL released), so the file written is
    byte for byte the one `voxpack export` writes from the same bed.

    Parameters
    ----------
    bed : Bed, numpy array or path
        The bed. xdmf (a sidecar pointing into the bed file) and vtkhdf with link=True
        need a bed file path; an in-memory Bed is written to a temporary file for the
        other formats.
    format : str
        "stl", "obj" (surfaces), "xdmf" (sidecar), "vtkhdf", "vtk" (particle points),
        "tiff" (folder of slices), "nrrd", "mha" (indicator image), "csv" (particle table).
    output : path, optional
        Output file (a folder for tiff). Default for a bed file: beside it with the
        format's extension (bed.stl, bed_tiff/, ...); required for an in-memory bed.
    contacts : "none" | "gap" | "overlap" | "bridge" | "cap"
        stl/obj: treatment of particle-particle and particle-wall contacts (default none).
    contact_size : float
        In units of d: gap/overlap scale 1 -/+ S (default 0.01); bridge diameter and cap
        flat diameter S*d (default 0.2).
    contact_tolerance_mm : float
        Surfaces closer than this count as touching, mm (default one voxel).
    tolerance_mm : float
        Chord tolerance of the tessellation, mm (default d/500).
    wall : bool
        stl/obj: include the container wall solid (default True; False = `--no-wall`).
    surface : bool
        stl/obj: smoothed iso-surface of the indicator (imaged beds) instead of the exact
        particle surfaces; smoothing_voxels (Gaussian sigma, voxels, default 1) and
        taubin_iterations (default 10) shape it.
    link : bool
        vtkhdf: HDF5 external links into the bed file instead of copies.
    threads, memory_limit, progress : as in pack().

    Returns the `voxpack export --json` report as a dict (format, output, counts,
    tolerances, bytes); `input` is the path given, or None for an in-memory bed.
    Bad formats or options raise ValueError with the CLI's message.
    """
    if format not in _FORMATS:
        raise ValueError(f"format: expected one of {', '.join(_FORMATS)}, got {format!r}")
    if not _is_path(bed):
        if format == "xdmf" or (format == "vtkhdf" and link):
            raise ValueError(f"format {format!r}{' with link=True' if link else ''} points into "
                             "the bed file: pass the bed as a path (voxpack.write_bed it first)")
        if output is None:
            raise ValueError("output: required for an in-memory bed (there is no bed file to "
                             "write beside)")
    opts = {"contacts": contacts, "contact_size": contact_size,
            "contact_tolerance_mm": contact_tolerance_mm, "tolerance_mm": tolerance_mm,
            "no_wall": not wall, "surface": bool(surface), "smoothing_voxels": smoothing_voxels,
            "taubin_iterations": taubin_iterations, "link": bool(link)}
    with scratch() as tmp:
        if _is_path(bed):
            src, given = os.fspath(bed), os.fspath(bed)
        else:
            src, given = os.path.join(tmp, "bed.h5"), None
            write_bed(src, bed if isinstance(bed, Bed) else Bed(bed))
        args = global_args(threads, memory_limit) + ["export", src, "--format", format, "--json"]
        if output is not None:
            args += ["-o", os.fspath(output)]
        text = run_cli(args + flags(opts, {}), progress, hide=(tmp,), capture_stdout=True)
    report = json.loads(text)
    report["input"] = given
    return report
