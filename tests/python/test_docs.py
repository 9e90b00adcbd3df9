"""docs/python.md's worked example, run as a doctest from a scratch folder that sees the
checkout's samples/ (the page says: run from the checkout root)."""

import doctest
import os

import matplotlib

matplotlib.use("Agg")


def test_python_md_worked_example(tmp_path, source_dir, monkeypatch):
    os.symlink(source_dir / "samples", tmp_path / "samples")
    monkeypatch.chdir(tmp_path)
    result = doctest.testfile(str(source_dir / "docs" / "python.md"), module_relative=False,
                              optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE,
                              verbose=False)
    assert result.attempted > 20
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed"
    assert (tmp_path / "radial_profiles.png").stat().st_size > 1000
    assert (tmp_path / "mc_particles.csv").read_text().startswith("id,shape,")
