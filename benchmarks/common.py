"""Shared by the benchmark scripts: scenes, the thesis's published figures, result writing."""

from __future__ import annotations

import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import trimesh
from shapely.geometry import Polygon, box

ROOT = Path(__file__).resolve().parents[1]
MESHES = ROOT / "meshes"
RESULTS = Path(__file__).resolve().parent / "results"
sys.path.insert(0, str(ROOT / "src"))

# Thesis chapter 4 (MATLAB, grid cells of 1 m, d_opt 7, security 3, 80 deg FOV). Per path:
# shots, path length (cells), planning time (s).
THESIS_3D = {
    "prism": {"table": "4.4", "paths": {"rooftop": (22, 108, 50.492), "facades": (45, 267, 125.537)}},
    "ring": {"table": "4.5", "paths": {"terrace": (51, 175, 126.493), "opposed terrace": (21, 94, 49.243),
                                       "rooftop": (51, 178, 152.091), "facades": (57, 312, 192.571)}},
    "pyramid": {"table": "4.6", "paths": {"rooftop": (8, 27, 16.112), "facades": (53, 307, 158.246)}},
}
THESIS_2D = {  # Table 4.2: shots, path length, time, nt-imaged, d-image, db-viewpoints, p-outliers
    "square": (17, 79, 49.922, 2.5, 6.77, 5.512, 5),
    "l": (21, 96, 65.359, 2.337, 6.901, 4.947, 3),
    "h": (26, 100, 91.302, 2.4, 6.671, 4.206, 3),
    "triangle": (18, 71, 52.371, 2.6, 6.591, 4.398, 8),
}
THESIS_2D_OBSTACLES = {  # Table 4.3: mean (std) over 10 configurations
    "square": {"shots": (18.1, 1.044), "path": (97.4, 16.499), "time": (48.808, 2.345),
               "nt_imaged": (2.466, 0.055), "d_image": (6.818, 0.129), "db": (5.219, 0.393),
               "p_outliers": (2.6, 1.280)},
    "l": {"shots": (22.2, 1.166), "path": (110.6, 20.367), "time": (78.483, 8.359),
          "nt_imaged": (2.463, 0.081), "d_image": (6.856, 0.069), "db": (4.886, 0.23),
          "p_outliers": (3.5, 1.565)},
}


def thesis_totals(name):
    paths = THESIS_3D[name]["paths"].values()
    return tuple(sum(p[i] for p in paths) for i in range(3))


def big_building(n_faces: int = 50_000) -> trimesh.Trimesh:
    """An L-shaped block with a tower, a raised wing and a balcony, subdivided to ~n_faces."""
    base = trimesh.creation.extrude_polygon(Polygon([(0, 0), (40, 0), (40, 25), (22, 25), (22, 40), (0, 40)]), 18.0)
    tower = trimesh.creation.box(extents=[10, 10, 14])
    tower.apply_translation([8, 8, 25])
    wing = trimesh.creation.extrude_polygon(box(2, 27, 20, 38), 4.0)
    wing.apply_translation([0, 0, 18])
    balcony = trimesh.creation.box(extents=[12, 2, 0.4])
    balcony.apply_translation([30, -1, 9])
    mesh = trimesh.boolean.union([base, tower, wing, balcony], engine="manifold")
    best = None
    for edge in np.geomspace(0.3, 3.0, 40):  # split levels differ per face: pick the nearest count
        v, f = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=edge)
        if best is None or abs(len(f) - n_faces) < abs(len(best[1]) - n_faces):
            best = (v, f)
    return trimesh.Trimesh(*best)


def timed(func, repeats: int):
    """(median seconds, last result) of ``repeats`` calls."""
    times, result = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        result = func()
        times.append(time.perf_counter() - t)
    return statistics.median(times), result


def machine() -> dict:
    return {"platform": platform.platform(), "processor": platform.processor() or platform.machine(),
            "cpus": os.cpu_count(), "python": platform.python_version()}


def result_path(name: str, quick: bool) -> Path:
    """Where ``write_json`` writes benchmark ``name``'s results."""
    return RESULTS / (f"{name}_quick.json" if quick else f"{name}.json")


def write_json(name: str, quick: bool, payload: dict) -> Path:
    RESULTS.mkdir(exist_ok=True)
    path = result_path(name, quick)
    path.write_text(json.dumps({"machine": machine(), **payload}, indent=1, default=float))
    return path


def table(rows: list[dict], columns: list[tuple[str, str, str]]) -> str:
    """Plain-text table: columns are (key, header, format)."""
    cells = [[h for _k, h, _f in columns]]
    for r in rows:
        cells.append([("-" if r.get(k) is None else format(r[k], f)) for k, _h, f in columns])
    widths = [max(len(c[i]) for c in cells) for i in range(len(columns))]
    return "\n".join("  ".join(c[i].rjust(widths[i]) for i in range(len(columns))) for c in cells)
