"""The thesis's 3D scenes (Chapter 4.2): its Tables 4.4-4.6 beside the voxel baseline and the
mesh planner, both judged by the one evaluator under the thesis's and the strict rule.

Prism; prism with a ring (terrace and opposed terrace); pyramid; prism with a large and a
small obstacle (Figure 4.11, the small one floating between the thesis's slices). 1 m cells,
d_opt 7 m, security 3 m, 80 deg horizontal FOV and the thesis's 10 m vertical coverage at
d_opt (a camera of 80 x 71 deg), start in the upper-left corner at 0.5 m. Per path, the
thesis's shots / coverage-path length / time beside the baseline's; then both planners'
totals. ``--quick``: the prism only.
"""

from __future__ import annotations

import argparse
import statistics
import time

from common import MESHES, THESIS_3D, table, thesis_totals, write_json
from coverplan import evaluate, load_scene, plan
from coverplan.voxel import plan_3d, thesis_camera

SCENES = {"prism": ("thesis_prism.obj", []), "ring": ("ring_prism.obj", []), "pyramid": ("pyramid.obj", []),
          "fig411": ("thesis_prism.obj", ["fig411_obstacles.obj"])}
START = [0.5, 49.5, 0.5]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    camera = thesis_camera()
    gsd = float(camera.gsd_at(7.0))
    names = ["prism"] if args.quick else list(SCENES)
    path_rows, totals = [], []
    for name in names:
        target, obstacles = SCENES[name]
        scene = load_scene(MESHES / target, [MESHES / o for o in obstacles])
        t = time.perf_counter()
        vox = plan_3d(scene, camera, gsd, 3.0, START)
        vox_s = time.perf_counter() - t
        thesis_paths = list(THESIS_3D.get(name, {}).get("paths", {}).items())
        for flight in vox.flights:
            kind = flight.name.split(" at ")[0]
            match = next((v for k, v in thesis_paths if k == kind), None)
            path_rows.append({"scene": name, "path": flight.name, "voxel_shots": flight.n_shots,
                              "voxel_path_m": flight.coverage_length, "voxel_s": flight.seconds,
                              "thesis_shots": match[0] if match else None, "thesis_path": match[1] if match else None,
                              "thesis_s": match[2] if match else None, "failure": flight.failure})
        t = time.perf_counter()
        route = plan(scene, camera, gsd=gsd, security=3.0, start=START)
        mesh_s = time.perf_counter() - t
        for planner, r, seconds in (("voxel", vox.route, vox_s), ("mesh", route, mesh_s)):
            row = {"scene": name, "planner": planner, "plan_s": seconds}
            if r is not None:
                strict, thesis = (evaluate(r, scene, rule=rule).metrics for rule in ("strict", "thesis"))
                row.update({"shots": strict["shots"], "path_m": r.path_length, "coverage_path_m": r.coverage_length,
                            "cover_thesis_pct": thesis["coverage_pct"], "cover_strict_pct": strict["coverage_pct"],
                            "p_outliers_strict": strict["p_outliers"], "min_clearance_m": strict["min_clearance_m"],
                            "safe": strict["safe"], "unsafe_segments": strict["unsafe_segment_count"],
                            "failures": len(vox.failures) if planner == "voxel" else 0})
            totals.append(row)
        totals[-1]["voxel_over_mesh_time"] = vox_s / mesh_s
        if name in THESIS_3D:
            shots, length, seconds = thesis_totals(name)
            totals.append({"scene": name, "planner": f"thesis (Table {THESIS_3D[name]['table']})", "shots": shots,
                           "coverage_path_m": length, "plan_s": seconds})
        print(f"  {name} done", flush=True)
    print("Per path: the voxel baseline beside the thesis (coverage paths only, as its tables):")
    print(table(path_rows, [("scene", "scene", ""), ("path", "path", ""), ("thesis_shots", "thesis shots", "d"),
                            ("voxel_shots", "voxel shots", "d"), ("thesis_path", "thesis path", "d"),
                            ("voxel_path_m", "voxel path m", ".0f"), ("thesis_s", "thesis s", ".1f"),
                            ("voxel_s", "voxel s", ".2f"), ("failure", "failure", "")]))
    print("Whole flights, judged by the evaluator (thesis rule: in view, in sight, facing, any range):")
    print(table(totals, [("scene", "scene", ""), ("planner", "planner", ""), ("shots", "shots", "d"),
                         ("coverage_path_m", "coverage path m", ".0f"), ("path_m", "flight m", ".0f"),
                         ("plan_s", "plan s", ".2f"), ("cover_thesis_pct", "cover% thesis rule", ".1f"),
                         ("cover_strict_pct", "cover% strict", ".1f"), ("p_outliers_strict", "p-out strict", "d"),
                         ("min_clearance_m", "min clr m", ".2f"), ("unsafe_segments", "unsafe segs", "d")]))
    ratios = [r["voxel_over_mesh_time"] for r in totals if "voxel_over_mesh_time" in r]
    print(f"planning time voxel / mesh, same run: median {statistics.median(ratios):.2f}")
    out = write_json("thesis_3d", args.quick, {"rows": totals, "paths": path_rows,
                                               "time_ratio_voxel_over_mesh_median": statistics.median(ratios)})
    print(f"written {out}")


if __name__ == "__main__":
    main()
