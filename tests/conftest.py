from __future__ import annotations

import numpy as np
import pytest


def pytest_addoption(parser):
    parser.addoption("--slow", action="store_true", default=False, help="also run tests marked slow")


# The longest groups of the suite (minutes each), started first so that the two workers of
# ``-n auto --dist loadgroup`` share them instead of one ending the run with a long tail.
LONG_GROUPS = ("field", "random_scenes_1", "random_scenes_2", "photos_check", "benchmark_reconstruction",
               "random_scenes_lanes", "real_photos")


def _group(item) -> str | None:
    mark = item.get_closest_marker("xdist_group")
    return (mark.args[0] if mark.args else mark.kwargs.get("name")) if mark else None


# The fast tier (``pytest -m "not slow_sim"``) leaves out the long groups and every test that
# renders photos and runs COLMAP, or runs the benchmark scripts.
SLOW_SIM_MODULES = ("test_simulate", "test_check", "test_benchmarks")


def pytest_collection_modifyitems(config, items):
    for item in items:
        if _group(item) in LONG_GROUPS or item.module.__name__.rpartition(".")[2] in SLOW_SIM_MODULES:
            item.add_marker(pytest.mark.slow_sim)
    items.sort(key=lambda item: LONG_GROUPS.index(_group(item)) if _group(item) in LONG_GROUPS else len(LONG_GROUPS))
    if config.getoption("--slow"):
        return
    skip = pytest.mark.skip(reason="slow; run with --slow")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def thesis_camera():
    from coverplan import get_camera
    return get_camera("thesis80")


@pytest.fixture
def write_mesh(tmp_path):
    def write(mesh, name):
        path = tmp_path / name
        mesh.export(path)
        return path
    return write


np.set_printoptions(precision=4, suppress=True)


@pytest.fixture(scope="module")
def seed_only_draws():
    """Hypothesis draws from the test's seed alone: it also draws constants it finds in the
    source of loaded modules outside the test folders, which made the drawn scenes depend on
    the install (editable or not) and on which tests had run before in the worker."""
    from hypothesis.internal.conjecture import providers
    with pytest.MonkeyPatch.context() as patch:
        if hasattr(providers, "_get_local_constants"):  # hypothesis >= 6.131: internals, hence the guard
            patch.setattr(providers, "_get_local_constants", providers.Constants)
            patch.setattr(providers, "CONSTANTS_CACHE", type(providers.CONSTANTS_CACHE)(1024))
        yield


# The jobs several test files plan, planned once per test process.

@pytest.fixture(scope="session")
def house_job():
    """The gabled house for a Phantom 4 Pro at 4 mm/px, 3 m security (the simulate sample)."""
    from coverplan import get_camera, load_scene, plan
    from tests.helpers import MESHES
    scene = load_scene(MESHES / "gabled_house.obj")
    return scene, plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0)


@pytest.fixture(scope="session")
def ring_job():
    """The README's sample job: the ring prism for a Phantom 4 Pro at 4 mm/px, 3 m security."""
    from coverplan import get_camera, load_scene, plan
    from tests.helpers import MESHES
    scene = load_scene(MESHES / "ring_prism.obj")
    return scene, plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0)
