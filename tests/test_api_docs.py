"""The API reference builds from the docstrings with warnings as errors (a public entry point
without a numpydoc docstring, or with an undocumented parameter, fails), and each entry point's
example runs."""

from __future__ import annotations

import doctest
import subprocess
import sys

import pytest

import coverplan
from tests.helpers import ROOT

ENTRY_POINTS = [coverplan.load_scene, coverplan.get_camera, coverplan.plan, coverplan.evaluate, coverplan.Route,
                coverplan.simulate, coverplan.check]


def test_the_api_reference_builds_without_a_warning(tmp_path):
    pytest.importorskip("sphinx")
    pytest.importorskip("numpydoc")
    done = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                           str(ROOT / "docs" / "api"), str(tmp_path / "html")], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    assert (tmp_path / "html" / "index.html").exists()
    page = (tmp_path / "html" / "index.html").read_text(encoding="utf-8")
    for entry in ENTRY_POINTS:
        assert f"coverplan.{entry.__name__}" in page, entry.__name__


@pytest.mark.parametrize("entry", ENTRY_POINTS, ids=lambda e: e.__name__)
def test_each_entry_point_has_an_example_that_runs(entry, monkeypatch):
    """simulate's and check's examples need COLMAP and photos: they are shown, not run (their
    commands are run by test_simulate.py and test_check.py)."""
    tests = doctest.DocTestFinder(recurse=False).find(entry, globs={"Path": __import__("pathlib").Path})
    examples = [ex for t in tests for ex in t.examples]
    assert examples, f"{entry.__name__} has no example"
    monkeypatch.chdir(ROOT)  # the examples read meshes/ as a user in the repository would
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    for t in tests:
        runner.run(t)
    assert runner.failures == 0, f"{entry.__name__}: {runner.failures} failing example(s)"
