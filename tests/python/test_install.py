"""`cmake --install BUILD --prefix P` puts the package into P's site-packages (the
posix_prefix scheme's platlib for P, where Python looks for a prefix's packages), and it
imports from there with nothing of the build tree on the path."""

import os
import pathlib
import subprocess
import sys
import sysconfig

import pytest


def test_cmake_install_into_a_prefix(tmp_path):
    build = os.environ.get("VOXPACK_BUILD_DIR")
    if not build:
        pytest.skip("VOXPACK_BUILD_DIR not set (ctest sets it)")
    prefix = tmp_path / "prefix"
    p = subprocess.run(["cmake", "--install", build, "--prefix", str(prefix)],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stdout + p.stderr
    site = pathlib.Path(sysconfig.get_path("platlib", "posix_prefix",
                                           vars={"base": str(prefix), "platbase": str(prefix)}))
    assert (site / "voxpack" / "__init__.py").exists()
    assert list((site / "voxpack").glob("_voxpack*.so"))
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(site)
    code = ("import voxpack, numpy as np; print(voxpack.__file__); "
            "print(voxpack.stats(np.ones((4, 4, 4), bool), only=['axial'])['voxpack_version'])")
    q = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                       cwd=tmp_path)
    assert q.returncode == 0, q.stderr
    where, version = q.stdout.split()
    assert pathlib.Path(where).is_relative_to(site)
    assert version == __import__("voxpack").__version__
