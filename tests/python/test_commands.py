"""phantom and ingest errors through the module equal the CLI's."""

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


def test_ingest_missing_file_message_equals_cli(cli, tmp_path):
    p = cli("ingest", tmp_path / "missing.nrrd", "-o", tmp_path / "x.h5", check=False)
    assert p.returncode == 2
    with pytest.raises((ValueError, OSError)) as e:
        voxpack.ingest(tmp_path / "missing.nrrd")
    assert "error: " + str(e.value) == p.stderr.strip().splitlines()[-1]


def test_phantom_equals_cli(cli, tmp_path, small_bed_file):
    cli("phantom", small_bed_file, "--modality", "mri", "--snr", 8, "--seed", 3,
        "-o", tmp_path / "cli.nrrd")
    ref, spacing, origin = read_nrrd(str(tmp_path / "cli.nrrd"))
    img = voxpack.phantom(small_bed_file, modality="mri", snr=8, seed=3)
    assert img.array.tobytes() == ref.tobytes()
    assert img.spacing_mm == pytest.approx(spacing) and img.origin_mm == pytest.approx(origin)
    path = voxpack.phantom(voxpack.read_bed(small_bed_file), tmp_path / "py.nrrd",
                           modality="mri", snr=8, seed=3)
    assert read_nrrd(path)[0].tobytes() == ref.tobytes()


