"""pack(): the CLI's bytes for the same scene, progress, Ctrl-C, errors with the CLI's text."""

import _thread
import os
import tempfile
import threading
import time

import h5py
import numpy as np
import pytest

import voxpack

SCENE = dict(container="cylinder:d=12,h=16", voxel_size_mm=0.5, count=25)


def datasets(path):
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset):
                out[name] = obj[...]
        f.visititems(visit)
    return out


@pytest.mark.parametrize("mode, scene_file", [("mc", "spheres_mc.toml"), ("dem", "spheres_dem.toml")])
def test_pack_same_bytes_as_cli(tmp_path, cli, source_dir, mode, scene_file):
    config = source_dir / "samples" / scene_file
    extra = {"max_time_s": 0.3} if mode == "dem" else {}
    cli_out = tmp_path / "cli.h5"
    flags = ["--max-time", "0.3"] if mode == "dem" else []
    cli("--threads", "2", "pack", "--config", config, "--container", SCENE["container"],
        "--voxel-size", SCENE["voxel_size_mm"], "--count", SCENE["count"], "--seed", 7,
        *flags, "-o", cli_out)
    py_out = tmp_path / "py.h5"
    bed = voxpack.pack(scene=config, seed=7, threads=2, output=py_out, **SCENE, **extra)
    ref = datasets(cli_out)
    got = datasets(py_out)
    assert sorted(got) == sorted(ref)
    for name in ref:
        assert got[name].dtype == ref[name].dtype, name
        if ref[name].dtype.kind == "O":  # variable-length strings: compare the values
            assert got[name].tolist() == ref[name].tolist(), name
        else:
            assert got[name].tobytes() == ref[name].tobytes(), name
    # The returned Bed is that file.
    assert bed.indicator.tobytes() == ref["indicator"].tobytes()
    assert bed.labels.tobytes() == ref["labels"].tobytes()
    np.testing.assert_array_equal(bed.particles["position_mm"], ref["particles/position_mm"])
    assert bed.provenance["mode"] == mode and bed.provenance["seed"] == 7


def test_pack_keywords_equal_scene_dict(tmp_path):
    a = voxpack.pack(mode="mc", shape="sphere:d=3", seed=2, threads=1, **SCENE)
    b = voxpack.pack(scene={"mode": "mc", "shape": "sphere:d=3", "seed": 2, **SCENE,
                            "mc": {"rebound_probability": 0.1}}, threads=1)
    c = voxpack.pack(mode="mc", shape="sphere:d=3", seed=2, threads=1, rebound_probability=0.1,
                     **SCENE)
    assert a.indicator.tobytes() == b.indicator.tobytes() == c.indicator.tobytes()
    d = voxpack.pack(mode="mc", shape="sphere:d=3", seed=2, threads=1, rebound_probability=0.6,
                     **SCENE)
    assert d.indicator.tobytes() != a.indicator.tobytes()  # the option reached the packer


def test_progress_callback_receives_done_total():
    calls = []
    voxpack.pack(mode="mc", shape="sphere:d=3", seed=1, threads=1,
                 progress=lambda done, total: calls.append((done, total)), **SCENE)
    assert calls, "no progress reported"
    assert all(t == 1.0 and 0.0 <= d <= 1.0 for d, t in calls)
    stages = []
    voxpack.pack(mode="mc", shape="sphere:d=3", seed=1, threads=1,
                 progress=lambda done, total, stage: stages.append(stage), **SCENE)
    assert "mc packing" in stages


def test_progress_exception_stops_the_run():
    class Stop(Exception):
        pass

    def progress(done, total):
        raise Stop("from the callback")
    with pytest.raises(Stop, match="from the callback"):
        voxpack.pack(mode="mc", shape="sphere:d=3", seed=1, threads=1, progress=progress, **SCENE)


# Runs of minutes: MC fills a tall column with 20000 small spheres; DEM pours 8000
# (well below what the column holds, so neither ends early by a full container).
LONG = {"mc": dict(shape="sphere:d=2", container="cylinder:d=40,h=200", voxel_size_mm=0.25,
                   count=20000, seed=1),
        "dem": dict(shape="sphere:d=2", container="cylinder:d=30,h=100", voxel_size_mm=0.25,
                    count=8000, seed=1)}


@pytest.mark.parametrize("mode", ["mc", "dem"])
def test_keyboard_interrupt_stops_a_long_pack(tmp_path, monkeypatch, mode):
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    timer = threading.Timer(1.0, _thread.interrupt_main)
    t0 = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            # output= in the same folder: a cancelled run writes no partial bed there either
            # (MC throws Cancelled; DEM since app/pack_dem.cpp throws it too).
            voxpack.pack(mode=mode, threads=1, output=tmp_path / "bed.h5", **LONG[mode])
    finally:
        timer.cancel()
    elapsed = time.monotonic() - t0
    # The run would take minutes; it stops within a few polls of the interrupt.
    assert elapsed < 15, f"took {elapsed:.1f} s to stop"
    assert os.listdir(tmp_path) == [], "partial output left behind"


def test_errors_carry_the_cli_message(cli, tmp_path):
    args = dict(mode="mc", shape="sphere:d=0.5", container="cylinder:d=10,h=10",
                voxel_size_mm=1.0, count=3, seed=1)
    p = cli("pack", "--mode", "mc", "--shape", "sphere:d=0.5", "--container", "cylinder:d=10,h=10",
            "--voxel-size", 1.0, "--count", 3, "--seed", 1, "-o", tmp_path / "x.h5", check=False)
    assert p.returncode == 2
    with pytest.raises(ValueError) as e:
        voxpack.pack(**args)
    assert "error: " + str(e.value) == p.stderr.strip().splitlines()[-1]
    with pytest.raises(ValueError, match="unknown mode"):
        voxpack.pack(**{**args, "mode": "nope"})
    with pytest.raises(ValueError, match=r"unknown \[mc\] key 'no_such_option'"):
        voxpack.pack(**{**args, "shape": "sphere:d=3", "voxel_size_mm": 0.5}, no_such_option=1)
    with pytest.raises(ValueError, match="mode= is required"):
        voxpack.pack(shape="sphere:d=3", friction=0.2)
    with pytest.raises(OSError, match="no_scene.toml"):
        voxpack.pack(scene=tmp_path / "no_scene.toml")


def test_help_lists_options_and_units():
    doc = voxpack.pack.__doc__
    for word in ("voxel_size_mm", "fill_height_mm", "rebound_probability", "friction", "mm",
                 "threads", "progress", "seed"):
        assert word in doc
    for f in (voxpack.read_bed, voxpack.write_bed, voxpack.stats, voxpack.ingest,
              voxpack.phantom, voxpack.compare, voxpack.Bed):
        assert f.__doc__ and len(f.__doc__) > 200, f
