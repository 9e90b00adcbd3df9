"""voxpack.flow and voxpack.export equal `voxpack flow` / `voxpack export` on the same bed:
the flow JSON value for value, the exported files byte for byte."""

import json
import pathlib

import h5py
import numpy as np
import pytest

import voxpack

# The run's own records: where the input came from, how it was called, how long it took.
RUN_RECORDS = {"input", "command_line", "wall_s", "solver_wall_s", "mlups"}


def without_run_records(d):
    return {k: v for k, v in d.items() if k not in RUN_RECORDS}


def assert_same(got, ref, where="flow"):
    """Equal value for value (floats exactly: both come from the same JSON text path)."""
    if isinstance(ref, dict):
        assert isinstance(got, dict), where
        assert set(got) == set(ref), f"{where}: keys differ: {set(got) ^ set(ref)}"
        for k in ref:
            assert_same(got[k], ref[k], f"{where}.{k}")
    elif isinstance(ref, list):
        assert isinstance(got, list) and len(got) == len(ref), where
        for n, (g, r) in enumerate(zip(got, ref)):
            assert_same(g, r, f"{where}[{n}]")
    else:
        assert got == ref, f"{where}: {got!r} != {ref!r}"


FLOW_FLAGS = ("--tolerance", "1e-4", "--check-interval", "50")


@pytest.fixture(scope="module")
def cli_flow(cli, small_bed_file, tmp_path_factory):
    out = tmp_path_factory.mktemp("flow") / "cli.json"
    cli("--threads", "1", "flow", small_bed_file, "-o", out, *FLOW_FLAGS)
    return json.loads(out.read_text())


def test_flow_of_a_path_equals_cli(cli_flow, small_bed_file):
    got = voxpack.flow(small_bed_file, tolerance=1e-4, check_interval=50, threads=1)
    assert cli_flow["status"] == "converged" and cli_flow["permeability_mm2"] > 0
    assert got["input"] == str(small_bed_file)
    assert got["command_line"] == "python: voxpack.flow"
    assert_same(without_run_records(got), without_run_records(cli_flow))
    for key in ("wall_s", "mlups"):
        assert key in got


def test_flow_of_an_in_memory_bed_equals_cli(cli_flow, small_bed_file):
    bed = voxpack.read_bed(small_bed_file)
    calls = []
    # 2 threads: the solver sums in fixed blocks, so the result is the 1-thread one.
    got = voxpack.flow(bed, tolerance=1e-4, check_interval=50, threads=2,
                       progress=lambda done, total: calls.append((done, total)))
    assert got["input"] is None
    assert_same(without_run_records(got), without_run_records(cli_flow))
    assert calls and all(0 <= d <= t == 1.0 for d, t in calls)
    # A Fortran-ordered bool view of the same indicator, with the mask, gives the same k.
    other = voxpack.Bed(np.asfortranarray(bed.indicator.astype(bool)), mask=bed.mask,
                        spacing_mm=bed.spacing_mm, origin_mm=bed.origin_mm,
                        particles=bed.particles, provenance=bed.provenance)
    again = voxpack.flow(other, tolerance=1e-4, check_interval=50, threads=1)
    assert again["permeability_mm2"] == cli_flow["permeability_mm2"]


def test_flow_options_and_outputs_equal_cli(cli, small_bed_file, tmp_path):
    cli("--threads", "1", "flow", small_bed_file, "-o", tmp_path / "cli.json", "--roi-mm",
        "2:9", "--mirror", "--velocity-mm-s", "2.5", "--csv", tmp_path / "csv",
        *FLOW_FLAGS)
    ref = json.loads((tmp_path / "cli.json").read_text())
    got = voxpack.flow(small_bed_file, roi_mm=(2, 9), mirror=True, velocity_mm_s=2.5,
                       csv_dir=tmp_path / "pycsv", field=tmp_path / "field.h5", tolerance=1e-4,
                       check_interval=50, threads=1)
    assert ref["status"] == "converged" and ref["roi_mm"]["layers"] == 14  # centres 0.25 + 0.5 k in [2, 9]: k = 4..17
    assert_same(without_run_records(got), without_run_records(ref))
    assert ((tmp_path / "pycsv" / "radial_profile.csv").read_bytes()
            == (tmp_path / "csv" / "radial_profile.csv").read_bytes())
    with h5py.File(tmp_path / "field.h5", "r") as f:
        assert f["velocity"].shape == (14, 20, 22, 3) and f["pressure"].shape == (14, 20, 22)
    assert (tmp_path / "field.xdmf").exists()


def test_flow_errors_carry_the_cli_text(cli, small_bed_file, tmp_path):
    p = cli("flow", small_bed_file, "-o", tmp_path / "x.json", "--mirror", "--periodic",
            check=False)
    assert p.returncode == 2
    cli_text = p.stderr.strip().splitlines()[-1].removeprefix("error: ")
    with pytest.raises(ValueError) as e:
        voxpack.flow(small_bed_file, mirror=True, periodic=True)
    assert str(e.value) == cli_text == "--mirror and --periodic exclude each other"
    with pytest.raises(ValueError, match="axis"):
        voxpack.flow(small_bed_file, axis="w")
    with pytest.raises(ValueError, match="solid"):
        voxpack.flow(np.zeros((6, 6, 6), dtype=bool))
    with pytest.raises(OSError):
        voxpack.flow(tmp_path / "missing.h5")


# Formats compared byte for byte with the CLI; (format, extension, extra CLI flags,
# extra keywords). stl at a coarse chord tolerance keeps the mesh small.
CASES = [
    ("csv", "csv", (), {}),
    ("vtk", "vtk", (), {}),
    ("nrrd", "nrrd", (), {}),
    ("mha", "mha", (), {}),
    ("stl", "stl", ("--tolerance-mm", "0.05", "--contacts", "gap"),
     {"tolerance_mm": 0.05, "contacts": "gap"}),
    ("obj", "obj", ("--tolerance-mm", "0.05", "--no-wall"), {"tolerance_mm": 0.05, "wall": False}),
    ("stl", "stl", ("--surface", "--smoothing-voxels", "0.8"), {"surface": True,
                                                                "smoothing_voxels": 0.8}),
]


def files_of(path: pathlib.Path) -> dict:
    if path.is_dir():
        return {p.name: p.read_bytes() for p in sorted(path.iterdir())}
    return {path.name: path.read_bytes()}


@pytest.mark.parametrize("fmt,ext,flags,kw", CASES)
def test_export_equals_cli_bytes(cli, small_bed_file, tmp_path, fmt, ext, flags, kw):
    cli("--threads", "1", "export", small_bed_file, "--format", fmt, "-o",
        tmp_path / f"cli.{ext}", *flags)
    ref = (tmp_path / f"cli.{ext}").read_bytes()
    assert len(ref) > 100
    report = voxpack.export(small_bed_file, fmt, tmp_path / f"path.{ext}", threads=2, **kw)
    assert (tmp_path / f"path.{ext}").read_bytes() == ref
    assert report["format"] == fmt and report["output"] == str(tmp_path / f"path.{ext}")
    assert report["input"] == str(small_bed_file) and report["bytes"] == len(ref)
    # An in-memory Bed (written to a temporary bed file for the command) gives the same bytes.
    bed = voxpack.read_bed(small_bed_file)
    report = voxpack.export(bed, fmt, tmp_path / f"mem.{ext}", **kw)
    assert (tmp_path / f"mem.{ext}").read_bytes() == ref
    assert report["input"] is None


def test_export_tiff_folder_and_sidecars_equal_cli(cli, small_bed_file, tmp_path):
    cli("export", small_bed_file, "--format", "tiff", "-o", tmp_path / "cli_tiff")
    voxpack.export(voxpack.read_bed(small_bed_file), "tiff", tmp_path / "py_tiff")
    ref = files_of(tmp_path / "cli_tiff")
    assert len(ref) == voxpack.read_bed(small_bed_file).shape[0]
    assert files_of(tmp_path / "py_tiff") == ref
    # xdmf and linked vtkhdf point into the bed file: same folder, same text.
    for fmt, ext, link in (("xdmf", "xdmf", False), ("vtkhdf", "vtkhdf", True)):
        cli("export", small_bed_file, "--format", fmt, "-o", small_bed_file.parent / f"cli.{ext}",
            *(["--link"] if link else []))
        rep = voxpack.export(small_bed_file, fmt, small_bed_file.parent / f"py.{ext}", link=link)
        if fmt == "xdmf":
            assert ((small_bed_file.parent / f"py.{ext}").read_bytes()
                    == (small_bed_file.parent / f"cli.{ext}").read_bytes())
            assert "/indicator" in json.dumps(rep["datasets"]) or rep["datasets"]
        else:
            assert rep["linked"] is True
    # The default output: beside the bed with the format's extension.
    rep = voxpack.export(small_bed_file, "csv")
    assert rep["output"] == str(small_bed_file.with_suffix(".csv"))
    assert small_bed_file.with_suffix(".csv").exists()


def test_export_errors(cli, small_bed_file, tmp_path):
    bed = voxpack.read_bed(small_bed_file)
    with pytest.raises(ValueError, match="path"):
        voxpack.export(bed, "xdmf", tmp_path / "x.xdmf")
    with pytest.raises(ValueError, match="output"):
        voxpack.export(bed, "stl")
    with pytest.raises(ValueError, match="format"):
        voxpack.export(small_bed_file, "ply", tmp_path / "x.ply")
    p = cli("export", small_bed_file, "--format", "stl", "--contacts", "glue", "-o",
            tmp_path / "c.stl", check=False)
    assert p.returncode == 2
    cli_text = p.stderr.strip().splitlines()[-1].removeprefix("error: ")
    with pytest.raises(ValueError) as e:
        voxpack.export(small_bed_file, "stl", tmp_path / "p.stl", contacts="glue")
    assert str(e.value) == cli_text
    assert not (tmp_path / "p.stl").exists()
    # A bed without a particle table has no particle surfaces (the CLI's message).
    with pytest.raises(ValueError):
        voxpack.export(voxpack.Bed(bed.indicator), "stl", tmp_path / "q.stl")


def test_help_lists_the_options_with_units():
    flow_doc = voxpack.flow.__doc__
    for word in ("axis", "periodic", "mirror", "reservoir_layers", "tolerance", "max_steps",
                 "check_interval", "tau", "field", "csv_dir", "roi_mm", "velocity_mm_s",
                 "mm/s", "viscosity_pa_s", "Pa s", "density_kg_m3", "kg/m^3",
                 "particle_diameter_mm", "threads", "progress", "KeyboardInterrupt"):
        assert word in flow_doc, word
    export_doc = voxpack.export.__doc__
    for word in ("stl", "obj", "xdmf", "vtkhdf", "vtk", "tiff", "nrrd", "mha", "csv", "contacts",
                 "contact_size", "contact_tolerance_mm", "tolerance_mm", "wall", "surface",
                 "smoothing_voxels", "voxels", "link", "mm"):
        assert word in export_doc, word


def test_flow_walls_equal_cli(cli, small_bed_file, tmp_path):
    cli("--threads", "1", "flow", small_bed_file, "-o", tmp_path / "cli.json", "--walls",
        "interpolated", *FLOW_FLAGS)
    ref = json.loads((tmp_path / "cli.json").read_text())
    got = voxpack.flow(small_bed_file, walls="interpolated", tolerance=1e-4, check_interval=50,
                       threads=1)
    assert ref["walls"] == "interpolated"
    for d in (got, ref):  # the distance's own timing is a run record too
        assert d["wall_geometry"].pop("distance_s") >= 0
    assert_same(without_run_records(got), without_run_records(ref))
    with pytest.raises(ValueError, match="walls"):
        voxpack.flow(small_bed_file, walls="exact")
    # mass_correction=False is the CLI's --no-mass-correction.
    cli("--threads", "1", "flow", small_bed_file, "-o", tmp_path / "off.json", "--walls",
        "interpolated", "--no-mass-correction", *FLOW_FLAGS)
    ref = json.loads((tmp_path / "off.json").read_text())
    got = voxpack.flow(small_bed_file, walls="interpolated", tolerance=1e-4, check_interval=50,
                       threads=1, mass_correction=False)
    assert ref["mass_correction_relative"] == 0.0
    for d in (got, ref):
        d["wall_geometry"].pop("distance_s")
    assert_same(without_run_records(got), without_run_records(ref))
