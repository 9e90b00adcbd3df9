"""Beds: read_bed against h5py, write_bed read by the CLI, array layouts and dtypes."""

import json

import h5py
import numpy as np
import pytest

import voxpack


def test_read_bed_equals_h5py(small_bed_file):
    bed = voxpack.read_bed(small_bed_file)
    with h5py.File(small_bed_file, "r") as f:
        for name in ("indicator", "mask", "labels"):
            ref = f[name][...]
            got = getattr(bed, name)
            assert got.dtype == ref.dtype and got.shape == ref.shape
            np.testing.assert_array_equal(got, ref)
        np.testing.assert_array_equal(bed.particles["position_mm"], f["particles/position_mm"][...])
        np.testing.assert_array_equal(bed.particles["orientation"], f["particles/orientation"][...])
        assert list(bed.particles["shape"]) == [s.decode() for s in f["particles/shape"][...]]
        assert bed.spacing_mm == tuple(f.attrs["spacing_mm"])
        assert bed.origin_mm == tuple(f.attrs["origin_mm"])
        assert bed.provenance == json.loads(f.attrs["provenance"])
    assert voxpack.bed_datasets(small_bed_file)[:3] == ["/indicator", "/mask", "/labels"]


def test_read_bed_arrays_own_their_storage(small_bed_file):
    bed = voxpack.read_bed(small_bed_file)
    # Zero-copy: the array is a view on a capsule that owns the C++ vector, not a copy
    # held by numpy; it is C-contiguous and writeable.
    assert bed.indicator.base is not None and not isinstance(bed.indicator.base, np.ndarray)
    assert bed.indicator.flags.c_contiguous and bed.indicator.flags.writeable
    data = bed.indicator.copy()
    del bed
    import gc
    gc.collect()
    assert data.sum() > 0


def test_write_bed_then_cli_info(tmp_path, cli, small_bed_file):
    bed = voxpack.read_bed(small_bed_file)
    out = tmp_path / "copy.h5"
    voxpack.write_bed(out, bed)
    info = json.loads(cli("info", out, "--json").stdout)
    ref = json.loads(cli("info", small_bed_file, "--json").stdout)
    for key in ("dims", "spacing_mm", "origin_mm", "porosity", "packing_density"):
        assert info[key] == ref[key], key
    assert abs(info["porosity"] - bed.porosity) < 1e-12
    again = voxpack.read_bed(out)
    for name in ("indicator", "mask", "labels"):
        np.testing.assert_array_equal(getattr(again, name), getattr(bed, name))
    np.testing.assert_array_equal(again.particles["position_mm"], bed.particles["position_mm"])


def test_write_bool_array_true_is_void(tmp_path, cli):
    a = np.zeros((4, 5, 6), dtype=bool)
    a[1:3] = True                                  # 2 of 4 slices void
    voxpack.write_bed(tmp_path / "b.h5", a, spacing_mm=0.25)
    info = json.loads(cli("info", tmp_path / "b.h5", "--json").stdout)
    assert info["porosity"] == pytest.approx(0.5)
    assert info["spacing_mm"] == [0.25, 0.25, 0.25]
    np.testing.assert_array_equal(voxpack.read_bed(tmp_path / "b.h5").indicator, a.astype(np.uint8))


@pytest.mark.parametrize("layout", ["C", "F", "view", "reversed"])
def test_layouts_round_trip(tmp_path, layout):
    rng = np.random.default_rng(3)
    base = rng.random((9, 11, 13)) < 0.4
    if layout == "C":
        a, expect = base, base
    elif layout == "F":
        a, expect = np.asfortranarray(base), base
        assert not a.flags.c_contiguous
    elif layout == "view":
        big = rng.random((20, 25, 30)) < 0.4
        a = big[2:20:2, 3:25:2, 1:27:2]
        expect = np.ascontiguousarray(a)
        assert not a.flags.c_contiguous and not a.flags.f_contiguous
    else:
        a = base[::-1, :, ::-1]
        expect = np.ascontiguousarray(a)
    voxpack.write_bed(tmp_path / "l.h5", a)
    np.testing.assert_array_equal(voxpack.read_bed(tmp_path / "l.h5").indicator, expect)


def test_bool_view_is_zero_copy():
    a = np.zeros((3, 4, 5), dtype=bool)
    bed = voxpack.Bed(a)
    assert bed.indicator.dtype == np.uint8 and np.shares_memory(bed.indicator, a)
    assert bed.spacing_mm == (1.0, 1.0, 1.0)


@pytest.mark.parametrize("bad, message", [
    (np.zeros((4, 4)), "3-D"),
    (np.zeros((2, 3, 4, 5), dtype=np.uint8), "3-D"),
    (np.zeros((3, 3, 3), dtype=np.float64), "dtype float64"),
    (np.zeros((3, 3, 3), dtype=np.complex64), "dtype complex64"),
    (np.full((3, 3, 3), 2, dtype=np.int32), "only 0 and 1"),
    (np.zeros((0, 3, 3), dtype=bool), "empty"),
    (np.array([["a"]]), "3-D"),
])
def test_wrong_arrays_raise_value_error(bad, message, tmp_path):
    with pytest.raises(ValueError, match=message):
        voxpack.write_bed(tmp_path / "x.h5", bad)
    with pytest.raises(ValueError, match=message):
        voxpack.stats(bad)


def test_uint8_values_checked_by_core(tmp_path):
    a = np.zeros((3, 3, 3), dtype=np.uint8)
    a[1, 1, 1] = 7
    with pytest.raises(voxpack.FormatError, match=r"holds value 7 at \[1,1,1\]"):
        voxpack.write_bed(tmp_path / "x.h5", a)


def test_int_arrays_and_spacing():
    a = np.ones((3, 4, 5), dtype=np.int64)
    bed = voxpack.Bed(a, spacing_mm=(0.5, 0.25, 0.25))
    assert bed.indicator.dtype == np.uint8 and bed.spacing_mm == (0.5, 0.25, 0.25)
    with pytest.raises(ValueError, match="spacing_mm"):
        voxpack.Bed(a, spacing_mm=0)
    with pytest.raises(ValueError, match="mask"):
        voxpack.Bed(a, mask=np.ones((3, 4, 4), dtype=bool))


def test_errors_map_to_python_types(tmp_path):
    with pytest.raises(OSError, match="nothing.h5"):
        voxpack.read_bed(tmp_path / "nothing.h5")
    (tmp_path / "junk.h5").write_bytes(b"not hdf5 at all")
    with pytest.raises(OSError):
        voxpack.read_bed(tmp_path / "junk.h5")
    with h5py.File(tmp_path / "noformat.h5", "w") as f:
        f.create_dataset("indicator", data=np.zeros((2, 2, 2), np.uint8))
    with pytest.raises(ValueError, match="format") as e:
        voxpack.read_bed(tmp_path / "noformat.h5")
    assert isinstance(e.value, voxpack.FormatError) and isinstance(e.value, voxpack.InputError)
