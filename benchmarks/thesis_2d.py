"""The thesis's 2D experiments (Chapter 4.1): its Tables 4.2 and 4.3 beside the voxel baseline
and the mesh planner, all judged by the one evaluator.

The four shapes of Figure 4.1 (perimeters 60, 80, 90 and 60 m) in a 50 x 50 grid of 1 m
cells, d_opt 7 m, security 3 m, 80 deg horizontal FOV, start in the upper-left corner. The
voxel baseline plans the 2D grid; the mesh planner plans the same shape as a 1 m thin prism
(façades only, flying down to the ground). Both routes are evaluated on the prism's walls
under the thesis's rule (in view, in sight, facing: any range) and the strict one of docs/design.md.
Then the obstacle collections of 4.1.2: 3 big (9 m) and 5 small (4 m) square obstacles at
random, 10 fixed seeds each for the square and the L; configurations where an obstacle hides
part of the target are counted (the thesis dropped them), as voxel failures.
Path lengths are of the coverage path (first to last shot), as in the thesis's tables.
``--quick``: the square only, no obstacles.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np
import trimesh
from shapely.geometry import box as rect

from common import MESHES, THESIS_2D, THESIS_2D_OBSTACLES, table, write_json
from coverplan import evaluate, get_camera, plan
from coverplan.voxel import grid_from_polygons, plan_2d
from coverplan.world.scene import scene_from_meshes

sys.path.insert(0, str(MESHES))
from make_meshes import shapes_2d  # noqa: E402

START = (0.5, 49.5)
D_OPT, SECURITY = 7.0, 3.0


def obstacles(shape, seed: int):
    """3 big (9 m) and 5 small (4 m) squares at random in the grid, none overlapping the target
    or closer than the security distance (plus 1 m) to the start corner."""
    from shapely.geometry import Point
    rng = np.random.default_rng(seed)
    corner = Point(*START).buffer(SECURITY + 1.0)
    out = []
    for size, count in ((9.0, 3), (4.0, 5)):
        while sum(1 for o in out if o.area == size * size) < count:
            x, y = rng.uniform(0, 50 - size, 2)
            sq = rect(x, y, x + size, y + size)
            if not sq.intersects(shape) and not sq.intersects(corner):
                out.append(sq)
    return out


def judged(name, planner, route, scene, seconds, perimeter, failure=None):
    row = {"shape": name, "planner": planner, "time_s": seconds, "failure": failure}
    if route is None:
        return row
    strict = evaluate(route, scene, rule="strict", classes=("facade",)).metrics
    thesis = evaluate(route, scene, rule="thesis", classes=("facade",)).metrics
    row.update({"shots": thesis["shots"], "path_m": route.coverage_length, "total_path_m": route.path_length,
                "nt_imaged": thesis["nt_imaged"]["mean"], "d_image": thesis["d_image_m"]["mean"],
                "db_viewpoints": thesis["db_viewpoints_m"]["mean"], "p_outliers": thesis["p_outliers"],
                "p_surface1": thesis["shots"] / perimeter, "p_surface2": route.coverage_length / perimeter,
                "cover_thesis_pct": thesis["coverage_pct"], "cover_strict_pct": strict["coverage_pct"],
                "p_outliers_strict": strict["p_outliers"], "safe": strict["safe"],
                "min_clearance_m": strict["min_clearance_m"]})
    return row


def run_case(name, shape, obs, camera, gsd):
    perimeter = shape.length
    slab = trimesh.creation.extrude_polygon(shape, 1.0)
    obstacle_meshes = [trimesh.creation.extrude_polygon(o, 3.0) for o in obs]
    scene = scene_from_meshes([slab], obstacle_meshes, ground=0.0)
    t = time.perf_counter()
    vox = plan_2d(grid_from_polygons([shape], obs), camera, gsd, SECURITY, START, z=0.5, scene=scene)
    vox_s = time.perf_counter() - t
    rows = [judged(name, "voxel", vox.route, scene, vox_s, perimeter, "; ".join(vox.failures) or None)]
    t = time.perf_counter()
    route = plan(scene, camera, gsd=gsd, security=SECURITY, start=[*START, 0.5], min_altitude=0.0,
                 surface_classes=("facade",), spacing=0.5)
    rows.append(judged(name, "mesh", route, scene, time.perf_counter() - t, perimeter))
    rows[-1]["voxel_over_mesh_time"] = vox_s / rows[-1]["time_s"]
    return rows


COLUMNS = [("shape", "shape", ""), ("planner", "planner", ""), ("shots", "shots", "d"),
           ("path_m", "path m", ".0f"), ("time_s", "time s", ".2f"), ("nt_imaged", "nt-imaged", ".2f"),
           ("d_image", "d-image", ".2f"), ("db_viewpoints", "db-vp", ".2f"), ("p_outliers", "p-out", "d"),
           ("p_surface1", "p-surf1", ".3f"), ("p_surface2", "p-surf2", ".2f"),
           ("cover_thesis_pct", "cover% thesis rule", ".1f"), ("cover_strict_pct", "cover% strict", ".1f"),
           ("safe", "safe", "")]


def thesis_row(name):
    shots, path, seconds, nt, d, db, pout = THESIS_2D[name]
    perimeter = shapes_2d()[name].length
    return {"shape": name, "planner": "thesis", "shots": shots, "path_m": path, "time_s": seconds, "nt_imaged": nt,
            "d_image": d, "db_viewpoints": db, "p_outliers": pout, "p_surface1": shots / perimeter,
            "p_surface2": path / perimeter}


def summary(rows, name, planner):
    mine = [r for r in rows if r["planner"] == planner and r.get("shots") is not None]
    out = {"shape": name, "planner": planner, "configurations": len([r for r in rows if r["planner"] == planner]),
           "failures": len([r for r in rows if r["planner"] == planner and r.get("shots") is None])}
    for key in ("shots", "path_m", "time_s", "nt_imaged", "d_image", "db_viewpoints", "p_outliers",
                "p_surface1", "p_surface2", "cover_thesis_pct", "cover_strict_pct"):
        values = [float(r[key]) for r in mine]
        out[key] = statistics.mean(values) if values else None
        out[key + "_std"] = statistics.pstdev(values) if len(values) > 1 else None
    out["unsafe"] = len([r for r in mine if not r["safe"]])
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    camera = get_camera("thesis80")
    gsd = float(camera.gsd_at(D_OPT))
    shapes = shapes_2d()
    names = ["square"] if args.quick else list(shapes)
    rows = []
    for name in names:
        rows.append(thesis_row(name))
        rows += run_case(name, shapes[name], [], camera, gsd)
        print(f"  {name} done", flush=True)
    print("Without obstacles (thesis Table 4.2 beside both planners):")
    print(table(rows, COLUMNS))
    collections, summaries = {}, []
    if not args.quick:
        for name in ("square", "l"):
            runs = []
            for seed in range(10):
                runs += run_case(name, shapes[name], obstacles(shapes[name], seed), camera, gsd)
            collections[name] = runs
            t = THESIS_2D_OBSTACLES[name]
            summaries.append({"shape": name, "planner": "thesis", "configurations": 10, "failures": "dropped",
                              "shots": t["shots"][0], "shots_std": t["shots"][1], "path_m": t["path"][0],
                              "path_m_std": t["path"][1], "time_s": t["time"][0], "nt_imaged": t["nt_imaged"][0],
                              "d_image": t["d_image"][0], "db_viewpoints": t["db"][0], "p_outliers": t["p_outliers"][0]})
            summaries += [summary(runs, name, "voxel"), summary(runs, name, "mesh")]
            print(f"  obstacles {name} done", flush=True)
        print("With 3 big and 5 small random obstacles, 10 configurations each (thesis Table 4.3: mean and std):")
        print(table(summaries, [("shape", "shape", ""), ("planner", "planner", ""), ("configurations", "runs", "d"),
                                ("failures", "no path", ""), ("shots", "shots", ".1f"), ("shots_std", "(std)", ".2f"),
                                ("path_m", "path m", ".1f"), ("path_m_std", "(std)", ".1f"), ("time_s", "time s", ".2f"),
                                ("nt_imaged", "nt-imaged", ".2f"), ("d_image", "d-image", ".2f"),
                                ("db_viewpoints", "db-vp", ".2f"), ("p_outliers", "p-out", ".1f"),
                                ("cover_thesis_pct", "cover% thesis", ".1f"), ("cover_strict_pct", "cover% strict", ".1f"),
                                ("unsafe", "unsafe", "")]))
    ratios = [r["voxel_over_mesh_time"] for r in rows if "voxel_over_mesh_time" in r]
    for runs in collections.values():
        ratios += [r["voxel_over_mesh_time"] for r in runs if "voxel_over_mesh_time" in r]
    print(f"planning time voxel / mesh, same run: median {statistics.median(ratios):.2f} over {len(ratios)} cases")
    path = write_json("thesis_2d", args.quick, {"rows": rows, "obstacle_runs": collections, "summaries": summaries,
                                                "time_ratio_voxel_over_mesh_median": statistics.median(ratios)})
    print(f"written {path}")


if __name__ == "__main__":
    main()
