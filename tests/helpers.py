"""Shared test helpers: scene builders, sample paths and a loader for script files."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import trimesh

ROOT = Path(__file__).resolve().parents[1]
MESHES = ROOT / "meshes"


def box(x0, y0, z0, x1, y1, z1) -> trimesh.Trimesh:
    mesh = trimesh.creation.box(extents=[x1 - x0, y1 - y0, z1 - z0])
    mesh.apply_translation([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2])
    return mesh


def gsd_for(camera, d_opt: float) -> float:
    """The GSD whose optimal distance is ``d_opt`` for this camera."""
    return float(camera.gsd_at(d_opt))


# A house near Stuttgart: a 10 x 8 x 6 m box whose corner sits at these UTM 32N coordinates.
UTM_EAST, UTM_NORTH, UTM_BASE = 512_300.0, 5_403_830.0, 250.0


def utm_house(tmp_path, base: float = UTM_BASE):
    """The box in EPSG:25832 coordinates, written as an OBJ; returns its path."""
    mesh = box(0, 0, 0, 10, 8, 6)
    mesh.apply_translation([UTM_EAST, UTM_NORTH, base])
    path = tmp_path / "house.obj"
    mesh.export(path)
    return path


def load_script(path: Path):
    """A stand-alone script (meshes/make_meshes.py) as a module, without touching sys.path."""
    spec = importlib.util.spec_from_file_location(f"_script_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
