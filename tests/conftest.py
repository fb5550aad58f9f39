from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

sys.path.insert(0, str(Path(__file__).parent))

ROOT = Path(__file__).resolve().parents[1]
MESHES = ROOT / "meshes"


def pytest_addoption(parser):
    parser.addoption("--slow", action="store_true", default=False, help="also run tests marked slow")


def pytest_collection_modifyitems(config, items):
    if config.getoption("--slow"):
        return
    skip = pytest.mark.skip(reason="slow; run with --slow")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)


def box(x0, y0, z0, x1, y1, z1) -> trimesh.Trimesh:
    mesh = trimesh.creation.box(extents=[x1 - x0, y1 - y0, z1 - z0])
    mesh.apply_translation([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2])
    return mesh


@pytest.fixture
def thesis_camera():
    from coverplan import get_camera
    return get_camera("thesis80")


def gsd_for(camera, d_opt: float) -> float:
    """The GSD whose optimal distance is ``d_opt`` for this camera."""
    return float(camera.gsd_at(d_opt))


@pytest.fixture
def write_mesh(tmp_path):
    def write(mesh, name):
        path = tmp_path / name
        mesh.export(path)
        return path
    return write


np.set_printoptions(precision=4, suppress=True)


# A house near Stuttgart: a 10 x 8 x 6 m box whose corner sits at these UTM 32N coordinates.
UTM_EAST, UTM_NORTH, UTM_BASE = 512_300.0, 5_403_830.0, 250.0


def utm_house(tmp_path, base: float = UTM_BASE):
    """The box in EPSG:25832 coordinates, written as an OBJ; returns its path."""
    mesh = box(0, 0, 0, 10, 8, 6)
    mesh.apply_translation([UTM_EAST, UTM_NORTH, base])
    path = tmp_path / "house.obj"
    mesh.export(path)
    return path
