"""Plan every sample scene (and a 50,000-triangle building) and judge each with the evaluator.

Thesis settings for the sample scenes: d_opt 7 m, security 3 m, 80 deg horizontal FOV. The
50k-triangle building uses a Phantom 4 Pro at 5 mm/px (d_opt 18.2 m) and 5 m security.
Planning time is the median of three runs. Beside ours: the thesis's Tables 4.4-4.6 (sum of
its separate paths; its times are from a 2013 laptop running MATLAB, not this machine), the
LP lower bound of the shot count over our candidate set, and one orbit at the standoff.
Coverage three ways: the planner's own figure (its 0.25 m check samples), the evaluator's
at 0.25 m and at 0.125 m (other seeds), with the planner's repair rounds and shots.
``--quick`` plans two scenes once.
"""

from __future__ import annotations

import argparse

from common import MESHES, THESIS_3D, big_building, table, thesis_totals, timed, write_json
from coverplan import evaluate, get_camera, load_scene, plan
from coverplan.world.scene import scene_from_meshes

SCENES = {
    "square": ("square_prism.obj", []), "l": ("l_prism.obj", []), "h": ("h_prism.obj", []),
    "triangle": ("triangle_prism.obj", []), "prism": ("thesis_prism.obj", []),
    "ring": ("ring_prism.obj", []), "pyramid": ("pyramid.obj", []),
    "fig411": ("thesis_prism.obj", ["fig411_obstacles.obj"]), "gabled": ("gabled_house.obj", []),
    "courtyard": ("courtyard.obj", []), "flush": ("flush_target.obj", ["flush_obstacle.obj"]),
    "chapel": ("chapel.obj", []),
}

# (camera preset, gsd m/px or None for the GSD at the thesis's d_opt of 7 m, security m)
THESIS_SETTINGS = ("thesis80", None, 3.0)
BIG_SETTINGS = ("phantom4pro", 0.005, 5.0)  # the 50k-triangle building


def run_scene(name, scene, camera, gsd, security, repeats):
    seconds, route = timed(lambda: plan(scene, camera, gsd=gsd, security=security), repeats)
    m = evaluate(route, scene).metrics  # every 0.25 m, the evaluator's own seed
    finer = evaluate(route, scene, spacing=0.125).metrics["coverage_pct"]
    row = {"scene": name, "faces": sum(len(p.mesh.faces) for p in scene.parts), "shots": m["shots"],
           "lp_bound": route.metrics.get("lp_lower_bound_shots"), "path_m": m["path_length_m"],
           "orbit_m": route.metrics["orbit_length_m"], "coverage_pct": m["coverage_pct"],
           "unreachable_m2": m["unreachable_area_m2"], "p_outliers": m["p_outliers"],
           "min_clearance_m": m["min_clearance_m"], "safe": m["safe"], "plan_s": seconds,
           "linking_shots": route.metrics.get("linking_shots"), "photo_sets": m["shot_graph"]["components"],
           "short_of_neighbours": m["shot_graph"]["shots_short_of_neighbours"],
           "planned_pct": route.metrics["planned_coverage_pct"], "coverage_0125_pct": finer,
           "repair_rounds": route.metrics.get("repair_rounds"), "repair_shots": route.metrics.get("repair_shots")}
    # The LP bounds the covering shots; linking and repair shots come on top of it.
    covering = (row["shots"] + (route.metrics.get("redundant_shots_dropped") or 0) - (row["linking_shots"] or 0)
                - (row["repair_shots"] or 0))
    row["shots_over_lp"] = covering / row["lp_bound"] if row["lp_bound"] else None
    if name in THESIS_3D:
        row["thesis_shots"], row["thesis_path"], row["thesis_s"] = thesis_totals(name)
        row["thesis_table"] = THESIS_3D[name]["table"]
    return row


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    repeats = 1 if args.quick else 3
    camera = get_camera(THESIS_SETTINGS[0])
    gsd = float(camera.gsd_at(7.0))  # THESIS_SETTINGS' gsd None
    names = ["square", "prism"] if args.quick else list(SCENES)
    rows = []
    for name in names:
        target, obstacles = SCENES[name]
        scene = load_scene(MESHES / target, [MESHES / o for o in obstacles])
        rows.append(run_scene(name, scene, camera, gsd, THESIS_SETTINGS[2], repeats))
        print(f"  planned {name}", flush=True)
    if not args.quick:
        scene = scene_from_meshes([big_building(50_000)])
        big_camera, big_gsd, big_security = BIG_SETTINGS
        rows.append(run_scene("building50k", scene, get_camera(big_camera), big_gsd, big_security, repeats))
    print(table(rows, [("scene", "scene", ""), ("faces", "faces", "d"), ("shots", "shots", "d"),
                       ("linking_shots", "linking", "d"), ("lp_bound", "LP bound", ".1f"),
                       ("shots_over_lp", "covering/LP", ".2f"), ("photo_sets", "photo sets", "d"),
                       ("short_of_neighbours", "short", "d"),
                       ("path_m", "path m", ".0f"), ("orbit_m", "orbit m", ".0f"),
                       ("repair_rounds", "rounds", "d"), ("repair_shots", "repair", "d"),
                       ("planned_pct", "planned %", ".2f"), ("coverage_pct", "@0.25 m %", ".2f"),
                       ("coverage_0125_pct", "@0.125 m %", ".2f"), ("p_outliers", "p-out", "d"),
                       ("min_clearance_m", "min clr m", ".2f"), ("plan_s", "plan s", ".2f"),
                       ("thesis_shots", "thesis shots", "d"), ("thesis_path", "thesis path", "d"),
                       ("thesis_s", "thesis s", ".0f")]))
    path = write_json("plan_scenes", args.quick, {"repeats": repeats, "rows": rows})
    print(f"written {path}")


if __name__ == "__main__":
    main()
