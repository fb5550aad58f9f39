"""Evaluator speed: 500 shots against 50,000 surface samples on a 20,000-triangle scene.

Prints a table and writes benchmarks/results/evaluate_speed.json. ``--quick`` runs a small
version (the test suite does, so the script cannot rot).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import trimesh

from common import write_json
from coverplan import Route, evaluate, get_camera
from coverplan.shots.surface import sample_surface
from coverplan.shots.visibility import imaging_pairs
from coverplan.world.scene import scene_from_meshes


def building(n_faces: int) -> trimesh.Trimesh:
    """A 30 x 20 x 24 m block with a bumpy skin subdivided to about ``n_faces`` triangles."""
    mesh = trimesh.creation.box(extents=[30, 20, 24])
    mesh.apply_translation([0, 0, 12])
    best = None
    for edge in np.geomspace(0.3, 3.0, 40):  # split levels differ per side: pick the nearest count
        v, f = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=edge)
        if best is None or abs(len(f) - n_faces) < abs(len(best[1]) - n_faces):
            best = (v, f)
    mesh = trimesh.Trimesh(*best)
    rng = np.random.default_rng(0)
    top = mesh.vertices[:, 2] > 0.01
    mesh.vertices[top] += rng.normal(scale=0.02, size=(int(top.sum()), 3))
    return mesh


def orbit_route(camera, n_shots: int, gsd: float) -> Route:
    k = np.arange(n_shots)
    rings = 10
    per = n_shots // rings
    angle = 2 * np.pi * (k % per) / per
    z = 3 + (k // per) * 2.6
    pos = np.column_stack([26 * np.cos(angle), 21 * np.sin(angle), z])
    heading = np.degrees(np.arctan2(-pos[:, 0], -pos[:, 1])) % 360
    return Route(pos, np.ones(n_shots, bool), heading, np.zeros(n_shots), ["coverage"] * n_shots, camera,
                 {"gsd_m": gsd, "security_m": 3.0, "min_altitude_m": 1.0})


def run(n_faces: int, n_shots: int, n_samples: int, repeats: int) -> dict:
    camera = get_camera("phantom4pro")
    gsd = 0.007  # d_opt 25.5 m: every shot sees a good part of the wall
    scene = scene_from_meshes([building(n_faces)])
    area = scene.targets[0].mesh.area - 600
    spacing = float(np.sqrt(area / n_samples))
    samples = sample_surface(scene, spacing)
    route = orbit_route(camera, n_shots, gsd)
    times, cast_times = [], []
    pairs = None
    casts = {"rays": 0, "seconds": 0.0}
    blocked = scene.rays.segments_blocked

    def counted(starts, ends, *a, **k):  # how many occlusion rays Embree casts, and how fast
        t = time.perf_counter()
        out = blocked(starts, ends, *a, **k)
        casts["seconds"] += time.perf_counter() - t
        casts["rays"] += len(starts)
        return out
    scene.rays.segments_blocked = counted
    for _ in range(repeats):
        t = time.perf_counter()
        ev = evaluate(route, scene, samples=samples)
        times.append(time.perf_counter() - t)
        t = time.perf_counter()
        pairs = imaging_pairs(route.positions, route.heading_deg, route.pitch_deg, camera, samples.points,
                              samples.normals, scene.rays, max_range=route.d_opt, max_incidence_deg=70.0)
        cast_times.append(time.perf_counter() - t)
    return {"faces": int(len(scene.targets[0].mesh.faces)), "shots": n_shots, "samples": len(samples),
            "imaging_pairs": int(len(pairs[0])), "coverage_pct": ev.metrics["coverage_pct"],
            "evaluate_median_s": statistics.median(times), "visibility_median_s": statistics.median(cast_times),
            "occlusion_rays": casts["rays"], "rays_per_s": casts["rays"] / casts["seconds"],
            "pairs_per_s": len(pairs[0]) / statistics.median(cast_times)}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    sizes = [(2000, 60, 5000)] if args.quick else [(20000, 500, 50000)]
    rows = [run(f, s, n, 1 if args.quick else args.repeats) for f, s, n in sizes]
    print(f"{'faces':>7} {'shots':>6} {'samples':>8} {'imaging pairs':>14} {'evaluate s':>11} "
          f"{'visibility s':>13} {'pairs/s':>11} {'Embree rays/s':>14}")
    for r in rows:
        print(f"{r['faces']:>7} {r['shots']:>6} {r['samples']:>8} {r['imaging_pairs']:>14,} "
              f"{r['evaluate_median_s']:>11.2f} {r['visibility_median_s']:>13.2f} {r['pairs_per_s']:>11,.0f} "
              f"{r['rays_per_s']:>14,.0f}")
    print("evaluate s / visibility s: medians of the repeats; rays/s: occlusion rays over the time in Embree")
    out = write_json("evaluate_speed", args.quick, {"repeats": args.repeats, "rows": rows})
    print(f"written {out}")


if __name__ == "__main__":
    main()
