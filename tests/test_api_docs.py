"""The API reference builds from the docstrings with warnings as errors: the facade's page and
a page per subpackage covering every module, so a public function, class or method anywhere
without a numpydoc docstring, or with an undocumented parameter, fails. Each entry point's
example runs."""

from __future__ import annotations

import doctest
import functools
import importlib.util
import inspect
import re
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
    reference = "".join(p.read_text(encoding="utf-8") for p in (tmp_path / "html" / "reference").glob("*.html"))
    for module in _modules():  # every module has its page, with its own names on it
        assert f'id="{module}"' in reference or f'id="module-{module}"' in reference, module
    assert 'id="coverplan.shots.lanes.Lanes.subset"' in reference


def _conf():
    """docs/api/conf.py as a module: the reference's own walk of the package and its checks."""
    spec = importlib.util.spec_from_file_location("coverplan_api_conf", ROOT / "docs" / "api" / "conf.py")
    conf = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(conf)
    return conf


def _modules():
    return sorted(m for modules in _conf().public_modules().values() for m in modules)


def _public_names(conf):
    """What the reference documents: every function and class a module defines (not imports),
    and their public methods and properties."""
    for modules in conf.public_modules().values():
        for module_name in modules:
            module = importlib.import_module(module_name)
            for name in conf.own_names(module_name):
                yield f"{module_name}.{name}"
                obj = getattr(module, name)
                if inspect.isclass(obj):
                    for attr, member in vars(obj).items():
                        wrapped = getattr(member, "__func__", member)
                        if not attr.startswith("_") and (inspect.isfunction(wrapped) or isinstance(
                                member, (property, functools.cached_property))):
                            yield f"{module_name}.{name}.{attr}"


def test_every_public_function_and_class_has_a_numpydoc_docstring():
    """The reference's own checks (conf.py), name by name, so a failure lists what to write."""
    validate = pytest.importorskip("numpydoc.validate").validate
    conf = _conf()
    excluded = re.compile("|".join(conf.numpydoc_validation_exclude))
    names = [n for n in _public_names(conf) if not excluded.search(n)]
    assert len(names) > 700  # the walk finds the package's names
    bad = {}
    for name in names:
        codes = sorted(code for code, _ in validate(name)["errors"] if code in conf.numpydoc_validation_checks)
        if codes:
            bad[name] = codes
    assert not bad, "\n".join(f"{name}: {', '.join(codes)}" for name, codes in bad.items())


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
