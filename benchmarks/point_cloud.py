"""A 10-million-point LiDAR cloud of trees around a house, as obstacles: time and peak memory
of turning it into voxel obstacles, and of planning with them.

The cloud (LAZ, written once into results/): 60 trees (trunk and crown) around the gabled
sample house, a ground sheet (class 2) under everything, which is left out. Reading and
voxelising run in a fresh process so its peak memory is its own. ``--quick``: 200,000 points.
"""

from __future__ import annotations

import argparse
import multiprocessing
import resource
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from common import MESHES, RESULTS, table, write_json
from coverplan import evaluate, get_camera, load_scene, plan


def make_cloud(path, n_points: int, seed: int = 3) -> None:
    import laspy
    rng = np.random.default_rng(seed)
    n_trees = 60
    angle = rng.uniform(0, 2 * np.pi, n_trees)
    radius = rng.uniform(16, 45, n_trees)
    centres = np.column_stack([7 + radius * np.cos(angle), 4 + radius * np.sin(angle)])
    per_tree = int(n_points * 0.7 / n_trees)
    parts, classes = [], []
    for cx, cy in centres:
        d = rng.normal(size=(per_tree, 3))
        r = rng.uniform(2, 4)
        crown = [cx, cy, rng.uniform(6, 10)] + r * d / np.linalg.norm(d, axis=1, keepdims=True) * \
            rng.uniform(0, 1, (per_tree, 1)) ** (1 / 3)
        t = rng.uniform(0, 2 * np.pi, per_tree // 10)
        trunk = np.column_stack([cx + 0.25 * np.cos(t), cy + 0.25 * np.sin(t), rng.uniform(0, 6, len(t))])
        parts += [crown, trunk]
        classes += [np.full(len(crown), 5, np.uint8), np.full(len(trunk), 4, np.uint8)]
    n_ground = n_points - sum(len(p) for p in parts)
    ground = np.column_stack([rng.uniform(-50, 65, n_ground), rng.uniform(-50, 60, n_ground), rng.normal(0, 0.05, n_ground)])
    xyz = np.vstack(parts + [ground])
    header = laspy.LasHeader(point_format=0, version="1.2")
    header.scales = np.array([0.001, 0.001, 0.001])
    header.offsets = xyz.min(axis=0)
    las = laspy.LasData(header)
    las.x, las.y, las.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    las.classification = np.concatenate(classes + [np.full(n_ground, 2, np.uint8)])
    las.write(path)


def voxelise(path, resolution: float) -> dict:
    """In a fresh process: read and voxelise, with that process's peak memory."""
    from coverplan.world.pointcloud import point_obstacle
    t = time.perf_counter()
    mesh, note = point_obstacle(path, resolution)
    return {"seconds": time.perf_counter() - t, "triangles": len(mesh.faces), "note": note,
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    n = 200_000 if args.quick else 10_000_000
    RESULTS.mkdir(exist_ok=True)
    cloud = RESULTS / f"trees_{n}.laz"
    if not cloud.exists():
        t = time.perf_counter()
        make_cloud(cloud, n)
        print(f"  wrote {cloud.name} ({cloud.stat().st_size / 1e6:.0f} MB) in {time.perf_counter() - t:.1f} s")
    rows = []
    for resolution in ([0.5] if args.quick else [1.0, 0.5, 0.25]):
        with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
            row = pool.submit(voxelise, cloud, resolution).result()
        row.update({"points": n, "resolution_m": resolution})
        rows.append(row)
        print(f"  voxelised at {resolution} m: {row['note']}", flush=True)
    camera = get_camera("phantom4pro")
    house = MESHES / "gabled_house.obj"
    for label, extra in (("house alone", {}), ("house + trees @0.5 m", {"obstacle_points": [cloud]})):
        t = time.perf_counter()
        scene = load_scene(house, **extra)
        load_s = time.perf_counter() - t
        route = plan(scene, camera, gsd=0.003, security=2.0)
        ev = evaluate(route, scene)
        rows.append({"case": label, "load_s": load_s, "plan_s": route.metrics["planning_time_s"],
                     "shots": int(route.shot.sum()), "coverage_pct": ev.coverage_pct, "safe": ev.safe,
                     "min_clearance_m": ev.metrics["min_clearance_m"]})
    print(table([r for r in rows if "seconds" in r],
                [("points", "points", ",d"), ("resolution_m", "voxel m", "g"), ("seconds", "read+voxelise s", ".1f"),
                 ("peak_mb", "peak MB", ".0f"), ("triangles", "triangles", ",d")]))
    print(table([r for r in rows if "case" in r],
                [("case", "scene", ""), ("load_s", "load s", ".1f"), ("plan_s", "plan s", ".1f"), ("shots", "shots", "d"),
                 ("coverage_pct", "coverage %", ".2f"), ("min_clearance_m", "min clr m", ".2f"), ("safe", "safe", "")]))
    path = write_json("point_cloud", args.quick, {"rows": rows})
    print(f"written {path}")


if __name__ == "__main__":
    main()
