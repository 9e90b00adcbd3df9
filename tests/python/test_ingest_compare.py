"""ingest and compare through the module equal the CLI's results."""

import json

import h5py
import numpy as np
import pytest

import voxpack
from voxpack._run import read_nrrd


def volumes(path):
    with h5py.File(path, "r") as f:
        return {k: f[k][...] for k in ("indicator", "mask", "labels") if k in f}


@pytest.fixture(scope="module")
def sample(source_dir):
    return source_dir / "samples" / "reference_mri.nrrd"


def test_ingest_path_equals_cli(cli, tmp_path, sample):
    cli("--threads", "2", "ingest", sample, "-o", tmp_path / "cli.h5", "--void", "bright",
        "--column", "auto")
    bed = voxpack.ingest(sample, void="bright", column="auto", threads=2)
    ref = volumes(tmp_path / "cli.h5")
    assert bed.indicator.tobytes() == ref["indicator"].tobytes()
    assert bed.mask.tobytes() == ref["mask"].tobytes()
    assert bed.spacing_mm == pytest.approx((0.9, 0.9, 0.9))


def test_ingest_array_equals_ingest_file(sample):
    image, spacing, origin = read_nrrd(str(sample))
    assert image.shape == (69, 51, 51) and image.dtype == np.float32
    from_file = voxpack.ingest(sample, void="bright", column="auto", threads=1)
    from_array = voxpack.ingest(image, spacing_mm=spacing, origin_mm=origin, void="bright",
                                column="auto", threads=1)
    assert from_array.indicator.tobytes() == from_file.indicator.tobytes()
    assert from_array.mask.tobytes() == from_file.mask.tobytes()
    assert from_array.spacing_mm == pytest.approx(from_file.spacing_mm)
    assert from_array.origin_mm == pytest.approx(from_file.origin_mm)
    # Fortran order and a bad option.
    again = voxpack.ingest(np.asfortranarray(image), spacing_mm=spacing, origin_mm=origin,
                           void="bright", column="auto", threads=1)
    assert again.indicator.tobytes() == from_file.indicator.tobytes()
    with pytest.raises(ValueError, match="denoise"):
        voxpack.ingest(image, denoise="sharpen")
    with pytest.raises(ValueError, match="dtype"):
        voxpack.ingest(image.astype(np.complex64))


def test_compare_equals_cli(cli, tmp_path, small_bed_file):
    bed = voxpack.read_bed(small_bed_file)
    other = voxpack.Bed(np.flip(bed.indicator, axis=0), mask=bed.mask, spacing_mm=bed.spacing_mm,
                        origin_mm=bed.origin_mm)
    voxpack.write_bed(tmp_path / "flipped.h5", other)
    cli("compare", "--reference", small_bed_file, tmp_path / "flipped.h5", "-o", tmp_path / "cli",
        "--no-figures", "--particle-diameter", 3.2, "--bed-fraction", 0)
    ref = json.loads((tmp_path / "cli" / "summary.json").read_text())
    got = voxpack.compare(small_bed_file, {"flipped": other}, figures=False,
                          particle_diameter_mm=3.2, bed_fraction=0)
    assert got["candidates"][0]["name"] == ref["candidates"][0]["name"] == "flipped"
    for key in ("density_mean", "density_std", "density_rel_diff", "axial_ks_p", "radial_rmse",
                "s2_rmse", "mes_ks"):
        assert got["candidates"][0][key] == ref["candidates"][0][key], key
    kept = voxpack.compare(bed, [other], tmp_path / "kept", figures=False,
                           particle_diameter_mm=3.2, bed_fraction=0)
    assert (tmp_path / "kept" / "summary.json").exists() and (tmp_path / "kept" / "index.html").exists()
    assert kept["candidates"][0]["s2_rmse"] == ref["candidates"][0]["s2_rmse"]


def test_compare_flow_with_interpolated_walls_equals_cli(cli, tmp_path, small_bed_file):
    cli("--threads", "1", "compare", "--reference", small_bed_file, small_bed_file, "-o",
        tmp_path / "cli", "--no-figures", "--bed-fraction", 0, "--flow", "--flow-tolerance",
        "1e-4", "--flow-walls", "interpolated")
    ref = json.loads((tmp_path / "cli" / "summary.json").read_text())
    got = voxpack.compare(small_bed_file, [small_bed_file], figures=False, bed_fraction=0,
                          flow=True, flow_tolerance=1e-4, flow_walls="interpolated", threads=1)
    assert ref["options"]["flow_walls"] == got["options"]["flow_walls"] == "interpolated"
    for key in ("walls", "status", "permeability_mm2", "tortuosity_hydraulic", "wall_flow_share"):
        assert got["flow"]["reference"][key] == ref["flow"]["reference"][key], key
    assert got["flow"]["reference"]["walls"] == "interpolated"
    with pytest.raises(ValueError, match="need flow=True"):
        voxpack.compare(small_bed_file, [small_bed_file], figures=False, flow_walls="halfway")
