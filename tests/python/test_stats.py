"""stats(): the dict equals `voxpack stats` JSON value for value; any array layout."""

import json

import numpy as np
import pytest

import voxpack
from conftest import sphere_bed

# Keys that describe where the bed came from, so differ between a file on the command line
# and an array in memory (the array has no file name, command line or provenance).
CONTEXT_KEYS = ("input", "command_line", "input_provenance")
# Records of how the CLI process ran (its memory plan) that the in-memory call does not
# make; every statistic (and the packed_region record) must still be equal.
CLI_RUN_KEYS = {"memory_estimate_bytes"}


def strip(d, keys=CONTEXT_KEYS):
    return {k: v for k, v in d.items() if k not in keys}


def same_as_cli(got, ref, keys=CONTEXT_KEYS):
    extra = set(ref) - set(got)
    # Run records the CLI adds around the statistics may be absent (CLI_RUN_KEYS and any
    # later ones), never a statistic or the keys every stats JSON has.
    core = set(voxpack.statistic_names()) | {"porosity", "packing_density", "options",
                                             "voxpack_version", "roi_mm", "packed_region"}
    assert not (extra & core), f"statistics missing from the Python dict: {sorted(extra & core)}"
    assert set(got) <= set(ref), f"keys only in the Python dict: {sorted(set(got) - set(ref))}"
    ref = {k: v for k, v in ref.items() if k not in extra}
    d = diff(strip(got, keys), strip(ref, keys))
    assert d is None, d


def is_timing(key):
    """Wall-clock records inside the statistics (e.g. mes.seconds): never reproducible."""
    return key == "seconds" or key.endswith("_seconds") or key.startswith("wall_time")


def diff(a, b, path=""):
    """First difference between two JSON-like values (timings skipped), or None."""
    if isinstance(a, dict) and isinstance(b, dict):
        if a.keys() != b.keys():
            return f"{path}: keys {sorted(set(a) ^ set(b))}"
        for k in a:
            if is_timing(k):
                continue
            d = diff(a[k], b[k], f"{path}.{k}")
            if d:
                return d
        return None
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return f"{path}: length {len(a)} != {len(b)}"
        for n, (x, y) in enumerate(zip(a, b)):
            d = diff(x, y, f"{path}[{n}]")
            if d:
                return d
        return None
    if type(a) is not type(b) and not (isinstance(a, (int, float)) and isinstance(b, (int, float))
                                       and not isinstance(a, bool) and not isinstance(b, bool)):
        return f"{path}: {a!r} ({type(a).__name__}) != {b!r} ({type(b).__name__})"
    return None if a == b else f"{path}: {a!r} != {b!r}"


@pytest.fixture(scope="module")
def array_bed(tmp_path_factory):
    """An indicator + mask array and the bed file the CLI reads, written from the arrays."""
    indicator, mask, _, _ = sphere_bed(shape=(30, 26, 28), seed=5)
    path = tmp_path_factory.mktemp("stats") / "array.h5"
    voxpack.write_bed(path, indicator, mask=mask, spacing_mm=(0.4, 0.4, 0.4),
                      origin_mm=(0.2, -5.0, -5.4))
    return indicator, mask, path


def cli_stats(cli, path, tmp_path, *flags):
    out = tmp_path / "cli.json"
    cli("--threads", "1", "stats", path, "-o", out, *flags)
    return json.loads(out.read_text())


def test_stats_of_array_equals_cli_json(cli, tmp_path, array_bed):
    indicator, mask, path = array_bed
    ref = cli_stats(cli, path, tmp_path)
    got = voxpack.stats(indicator, mask=mask, spacing_mm=0.4, origin_mm=(0.2, -5.0, -5.4),
                        threads=1)
    for k in CONTEXT_KEYS:
        assert k in got and k in ref
    assert got["input"] is None and ref["input"] == str(path)
    same_as_cli(got, ref)
    for key in ("porosity", "packing_density", "axial", "radial", "s2", "mes"):
        assert key in got


def test_stats_of_file_and_bed_equal_cli(cli, tmp_path, small_bed_file):
    flags = ["--only", "axial,radial,s2,coordination", "--s2-max-lag-mm", "2", "--roi-mm", "1:9"]
    ref = cli_stats(cli, small_bed_file, tmp_path, *flags)
    kw = dict(only=["axial", "radial", "s2", "coordination"], s2_max_lag_mm=2, roi_mm=(1, 9),
              threads=1)
    got = voxpack.stats(str(small_bed_file), **kw)
    same_as_cli(got, ref, keys=("command_line",))
    bed = voxpack.read_bed(small_bed_file)
    got2 = voxpack.stats(bed, **kw)
    same_as_cli(got2, ref, keys=("input", "command_line"))
    assert got["roi_mm"]["z"] == [1.0, 9.0]


@pytest.mark.parametrize("layout", ["F", "view", "bool", "int64"])
def test_layouts_give_the_same_stats(layout):
    indicator, mask, _, _ = sphere_bed(shape=(20, 18, 16), seed=2)
    ref = voxpack.stats(indicator.astype(np.uint8), mask=mask, only=["axial", "s2"], threads=1)
    if layout == "F":
        a = np.asfortranarray(indicator.astype(np.uint8))
    elif layout == "view":
        big = np.zeros((40, 18, 32), dtype=np.uint8)
        big[::2, :, ::2] = indicator
        a = big[::2, :, ::2]
        assert not a.flags.c_contiguous
    elif layout == "bool":
        a = indicator
    else:
        a = indicator.astype(np.int64)
    got = voxpack.stats(a, mask=mask, only=["axial", "s2"], threads=1)
    assert diff(got, ref) is None


def test_stats_options_errors():
    a = np.ones((8, 8, 8), dtype=bool)
    with pytest.raises(ValueError, match="no statistic"):
        voxpack.stats(a, only=[])
    with pytest.raises(ValueError):
        voxpack.stats(a, only=["nonsense"])
    with pytest.raises(ValueError):
        voxpack.stats(a, roi_mm=(5, 1))
    assert "s2" in voxpack.statistic_names()


def test_packed_region_and_bed_window_equal_cli(cli, tmp_path, caplog):
    # The small bed under 16 empty slices of headspace (40 % of the mask): auto crops them.
    indicator, mask, labels, centres = sphere_bed(shape=(24, 20, 22), seed=0)
    pad = np.ones((16, 20, 22), dtype=bool)
    tall = np.concatenate([indicator, pad])
    tall_mask = np.concatenate([mask, np.broadcast_to(mask[:1], (16, 20, 22))])
    path = tmp_path / "tall.h5"
    voxpack.write_bed(path, tall, mask=tall_mask, spacing_mm=0.5)
    for mode in ("auto", "off"):
        ref = cli_stats(cli, path, tmp_path, "--only", "axial,radial,s2", "--packed-region", mode)
        with caplog.at_level("WARNING", logger="voxpack"):
            got = voxpack.stats(tall, mask=tall_mask, spacing_mm=0.5, only=["axial", "radial", "s2"],
                                packed_region=mode, threads=1)
        assert got["packed_region"] == ref["packed_region"]
        same_as_cli(got, ref)
        if mode == "auto":
            assert ref["packed_region"]["applied"] is True
        else:
            assert "outside the packed region" in caplog.text
    # bed_window: the CLI's refusals, word for word.
    p = cli("stats", path, "-o", tmp_path / "w.json", "--bed-window", check=False)
    with pytest.raises(ValueError) as e:
        voxpack.stats(path, bed_window=True)
    assert p.returncode == 2 and str(e.value) in p.stderr
    p = cli("stats", path, "-o", tmp_path / "w.json", "--bed-window", "--particle-diameter-mm",
            "3.2", check=False)
    with pytest.raises(ValueError) as e:
        voxpack.stats(path, bed_window=True, particle_diameter_mm=3.2)
    assert p.returncode == 2 and str(e.value) in p.stderr
    with pytest.raises(ValueError, match="packed-region"):
        voxpack.stats(path, packed_region="sometimes")
    # A window that fits: the bed with its particle table, d = 1 mm given.
    n = len(centres)
    bed = voxpack.Bed(tall, mask=tall_mask, spacing_mm=0.5,
                      particles={"position_mm": centres * 0.5,
                                 "orientation": np.tile([1.0, 0, 0, 0], (n, 1)),
                                 "shape": ["sphere:d=3.2"] * n})
    voxpack.write_bed(tmp_path / "window.h5", bed)
    ref = cli_stats(cli, tmp_path / "window.h5", tmp_path, "--only", "axial,s2", "--bed-window",
                    "--particle-diameter-mm", "1")
    got = voxpack.stats(bed, only=["axial", "s2"], bed_window=True, particle_diameter_mm=1,
                        threads=1)
    assert ref["roi_mm"]["bed_window_diameters"] == 2
    same_as_cli(got, ref)
