"""Battery-sized flights and the flight-time model.

Part 1: the courtyard building at 1.5 mm/px with a Mavic 3 Enterprise, split into flights of
at most 5, 10 and 14 minutes by the model. Per limit: flights, the longest flight by the model,
whether every flight starts and ends at the start point, whether the flights together take
exactly the one-flight plan's photos, the evaluator's safety verdict, and the path of all
flights over the single tour's (the price of landing in between), all from one run.

Part 2: the flight-time model beside the simple estimate (path at 5 m/s plus 1 s per photo)
on the sample scenes (thesis settings: 80 deg camera, d_opt 7 m, security 3 m), with the
model's parts: travel (accelerating, cruising, braking at every waypoint), waiting for the
yaw or gimbal, photos, take-off and landing.
Part 3: flying through (flight/passing.py) on the sample scenes with a Mavic 3 Enterprise
(4 mm/px, 3 m security): our default plan stopping at every waypoint and flown through, beside
QGroundControl's Structure Scan and the scan plus a nadir roof grid (70/70 overlap) flown
through by the same model and drone: photos, minutes, path, photos in passing, smooth steps
(consecutive photos within 10 deg of heading and 5 deg of gimbal pitch) and reversing steps
(the direction from one photo to the next turns by more than 90 deg) per 100 photos; and the
plan with square-on views only (``--view-tilts square``), the shortest tour
(``--reversal-cost 0 --reaim-cost 0``) and the tour without the re-aim cost (``--reaim-cost 0``)
beside the default, each re-checked by the evaluator (coverage at 0.25 m).
``--quick``: the ring prism (4 mm/px, 3 m security) at one limit, and three scenes. ``--parts``
runs some of the three (results/flights_PARTS.json when not all).
"""

from __future__ import annotations

import argparse

import numpy as np

from common import MESHES, table, write_json
from coverplan import evaluate, get_camera, load_scene, plan
from coverplan.equipment.drones import get_drone
from coverplan.equipment.flighttime import FlightModel
from coverplan.evaluation import view_limits
from coverplan.flight.lanes import route_step_shape
from coverplan.flight.passing import camera_timing, fly_through
from plan_scenes import SCENES
from structure_scan import scan_with_roof_grid, structure_scan


def same_shots(a, b, tol: float = 1e-6) -> bool:
    """Whether two routes photograph from the same poses, in any order: every shot of each has
    one of the other within ``tol`` in position (m) and in heading and pitch (as unit vectors).
    Rounding to a fixed number of decimals is not enough: a heading worked out again after the
    split can differ in its last bits and round the other way."""
    from scipy.spatial import cKDTree

    def poses(route):
        h, p = np.radians(route.heading_deg), np.radians(route.pitch_deg)
        return np.column_stack([route.positions, np.sin(h), np.cos(h), np.sin(p)])[route.shot]

    pa, pb = poses(a), poses(b)
    if len(pa) != len(pb):
        return False
    return all(np.isfinite(cKDTree(y).query(x, distance_upper_bound=tol)[0]).all() for x, y in ((pa, pb), (pb, pa)))


def split_rows(mesh: str, gsd: float, security: float, limits) -> list[dict]:
    scene = load_scene(MESHES / mesh)
    drone = get_drone("m3e")
    single = plan(scene, drone.camera, gsd=gsd, security=security, drone=drone, max_flight_min=1e6)
    rows = [{"limit_min": None, "flights": 1, "shots": int(single.shot.sum()),
             "longest_min": single.metrics["flights"][0]["minutes"], "total_min": single.metrics["single_flight_min"],
             "path_m": single.path_length, "path_ratio": 1.0, "home": True, "same_shots": True,
             "safe": evaluate(single, scene).safe, "plan_s": single.metrics["planning_time_s"],
             "split_s": 0.0}]
    for limit in limits:
        route = plan(scene, drone.camera, gsd=gsd, security=security, drone=drone, max_flight_min=limit)
        start = route.positions[0]
        home = all(np.allclose(route.positions[r[0]], start) and np.allclose(route.positions[r[-1]], start)
                   for r in route.flight_rows())
        minutes = [f["minutes"] for f in route.metrics["flights"]]
        rows.append({"limit_min": limit, "flights": route.n_flights, "shots": int(route.shot.sum()),
                     "longest_min": max(minutes), "total_min": sum(minutes), "path_m": route.path_length,
                     "path_ratio": route.path_length / single.path_length, "home": home,
                     "same_shots": same_shots(route, single),
                     "safe": evaluate(route, scene).safe, "plan_s": route.metrics["planning_time_s"],
                     "split_s": route.metrics["stage_seconds"].get("battery flights", 0.0)})
        print(f"  split at {limit} min", flush=True)
    return rows


def model_rows(names) -> list[dict]:
    camera = get_camera("thesis80")
    gsd = float(camera.gsd_at(7.0))
    model = FlightModel()  # 5 m/s, 2 m/s², 1 s per photo
    rows = []
    for name in names:
        target, obstacles = SCENES[name]
        scene = load_scene(MESHES / target, [MESHES / o for o in obstacles])
        route = plan(scene, camera, gsd=gsd, security=3.0, flight_model=model)
        f = route.metrics["flights"][0]
        simple = route.flight_minutes(5.0, 1.0)
        rows.append({"scene": name, "shots": f["shots"], "waypoints": f["waypoints"], "path_m": f["path_m"],
                     "simple_min": simple, "model_min": f["minutes"], "ratio": f["minutes"] / simple,
                     "travel_min": f["travel_s"] / 60, "wait_min": f["rotation_wait_s"] / 60,
                     "photos_min": f["photos_s"] / 60, "ground_min": f["takeoff_landing_s"] / 60})
        print(f"  timed {name}", flush=True)
    return rows


def through_rows(names, gsd: float = 0.004, security: float = 3.0) -> list[dict]:
    drone = get_drone("m3e")
    model = drone.flight_model()
    rows = []
    for name in names:
        target, obstacles = SCENES[name]
        scene = load_scene(MESHES / target, [MESHES / o for o in obstacles])
        ours = plan(scene, drone.camera, gsd=gsd, security=security, drone=drone, max_flight_min=1e6)
        timing = camera_timing(drone.camera, drone, model)
        square = plan(scene, drone.camera, gsd=gsd, security=security, drone=drone, max_flight_min=1e6,
                      view_tilts="square")
        shortest = plan(scene, drone.camera, gsd=gsd, security=security, drone=drone, max_flight_min=1e6,
                        reversal_steps=0.0, reaim_steps=0.0)
        noreaim = plan(scene, drone.camera, gsd=gsd, security=security, drone=drone, max_flight_min=1e6,
                       reaim_steps=0.0)
        flights = {"ours": ours, "square": square, "shortest": shortest, "noreaim": noreaim,
                   "scan": structure_scan(scene, drone.camera, gsd, security, ours.positions[0]),
                   "scan+grid": scan_with_roof_grid(scene, drone.camera, gsd, security, ours.positions[0])}
        row = {"scene": name, "ours_stop_min": ours.metrics["flights"][0]["minutes"]}
        for key, route in flights.items():
            if key in ("ours", "square", "shortest", "noreaim"):
                through = route.metrics["fly_through"]
                row[f"{key}_coverage_pct"] = evaluate(route, scene).coverage_pct
            else:
                route.params["drone"] = drone.name
                through = fly_through(route, scene, view_limits(route, scene), model, **timing)
            smooth, reverse = route_step_shape(route)
            row.update({f"{key}_photos": int(route.shot.sum()), f"{key}_min": through["minutes"],
                        f"{key}_path_m": route.path_length, f"{key}_passing_pct":
                        100.0 * through["photos_in_passing"] / max(int(route.shot.sum()), 1),
                        f"{key}_smooth_pct": smooth, f"{key}_reversals_per_100": reverse})
        row["through_vs_stop"] = row["ours_min"] / row["ours_stop_min"]
        row["ours_vs_grid_min"] = row["ours_min"] / row["scan+grid_min"]
        row["square_vs_grid_min"] = row["square_min"] / row["scan+grid_min"]
        row["shortest_vs_grid_min"] = row["shortest_min"] / row["scan+grid_min"]
        row["noreaim_vs_grid_min"] = row["noreaim_min"] / row["scan+grid_min"]
        rows.append(row)
        print(f"  flew {name}", flush=True)
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--parts", nargs="+", type=int, choices=[1, 2, 3], default=[1, 2, 3])
    args = parser.parse_args(argv)
    names = ["square", "gabled", "triangle"] if args.quick else list(SCENES)
    if 1 not in args.parts:
        splits = []
    elif args.quick:
        splits = split_rows("ring_prism.obj", 0.004, 3.0, [3.0])
    else:
        splits = split_rows("courtyard.obj", 0.0015, 2.0, [5.0, 10.0, 14.0])
    print(table(splits, [("limit_min", "limit min", "g"), ("flights", "flights", "d"), ("shots", "shots", "d"),
                         ("longest_min", "longest min", ".2f"), ("total_min", "total min", ".1f"),
                         ("path_m", "path m", ".0f"), ("path_ratio", "path x single", ".3f"),
                         ("home", "start=end", ""), ("same_shots", "same shots", ""), ("safe", "safe", ""),
                         ("split_s", "split s", ".2f"), ("plan_s", "plan s", ".1f")]))
    timings = model_rows(names) if 2 in args.parts else []
    print(table(timings, [("scene", "scene", ""), ("shots", "shots", "d"), ("waypoints", "waypoints", "d"),
                          ("path_m", "path m", ".0f"), ("simple_min", "simple min", ".1f"),
                          ("model_min", "model min", ".1f"), ("ratio", "model/simple", ".2f"),
                          ("travel_min", "travel", ".1f"), ("wait_min", "yaw/gimbal wait", ".2f"),
                          ("photos_min", "photos", ".1f"), ("ground_min", "take-off+landing", ".2f")]))
    passing = through_rows(names) if 3 in args.parts else []
    print(table(passing, [("scene", "scene", ""), ("ours_photos", "ours photos", "d"),
                          ("ours_stop_min", "ours stop min", ".1f"), ("ours_min", "ours through min", ".1f"),
                          ("ours_passing_pct", "in passing %", ".0f"), ("ours_smooth_pct", "smooth %", ".0f"),
                          ("ours_reversals_per_100", "reversals/100", ".0f"),
                          ("scan_photos", "scan photos", "d"), ("scan_min", "scan min", ".1f"),
                          ("scan+grid_photos", "scan+grid photos", "d"), ("scan+grid_min", "scan+grid min", ".1f"),
                          ("scan+grid_smooth_pct", "scan+grid smooth %", ".0f"),
                          ("scan+grid_reversals_per_100", "scan+grid rev/100", ".0f"),
                          ("through_vs_stop", "through/stop", ".2f"), ("ours_vs_grid_min", "ours/grid min", ".2f")]))
    print("--view-tilts square beside the default (varied):")
    print(table(passing, [("scene", "scene", ""), ("ours_photos", "ours photos", "d"),
                          ("square_photos", "square photos", "d"), ("ours_min", "ours through min", ".1f"),
                          ("square_min", "square through min", ".1f"), ("ours_smooth_pct", "ours smooth %", ".0f"),
                          ("square_smooth_pct", "square smooth %", ".0f"),
                          ("ours_reversals_per_100", "ours rev/100", ".0f"),
                          ("square_reversals_per_100", "square rev/100", ".0f"),
                          ("ours_coverage_pct", "ours @0.25 m %", ".2f"),
                          ("square_coverage_pct", "square @0.25 m %", ".2f"),
                          ("square_vs_grid_min", "square/grid min", ".2f")]))
    print("the default tour (reversal and re-aim costs) beside the shortest tour (--reversal-cost 0 --reaim-cost 0) "
          "and the tour without the re-aim cost (--reaim-cost 0), same photos:")
    print(table(passing, [("scene", "scene", ""), ("ours_photos", "photos", "d"),
                          ("shortest_min", "shortest through min", ".2f"), ("ours_min", "ours through min", ".2f"),
                          ("shortest_path_m", "shortest path m", ".0f"), ("ours_path_m", "ours path m", ".0f"),
                          ("shortest_passing_pct", "shortest in passing %", ".0f"),
                          ("ours_passing_pct", "ours in passing %", ".0f"),
                          ("shortest_reversals_per_100", "shortest rev/100", ".1f"),
                          ("ours_reversals_per_100", "ours rev/100", ".1f"),
                          ("shortest_smooth_pct", "shortest smooth %", ".0f"), ("ours_smooth_pct", "ours smooth %", ".0f"),
                          ("shortest_vs_grid_min", "shortest/grid min", ".2f"), ("ours_vs_grid_min", "ours/grid min", ".2f"),
                          ("ours_coverage_pct", "ours @0.25 m %", ".2f")]))
    print(table(passing, [("scene", "scene", ""), ("noreaim_min", "no re-aim through min", ".2f"),
                          ("ours_min", "ours through min", ".2f"), ("noreaim_path_m", "no re-aim path m", ".0f"),
                          ("ours_path_m", "ours path m", ".0f"), ("noreaim_smooth_pct", "no re-aim smooth %", ".0f"),
                          ("ours_smooth_pct", "ours smooth %", ".0f"),
                          ("noreaim_reversals_per_100", "no re-aim rev/100", ".1f"),
                          ("ours_reversals_per_100", "ours rev/100", ".1f"),
                          ("noreaim_passing_pct", "no re-aim in passing %", ".0f"),
                          ("ours_passing_pct", "ours in passing %", ".0f"),
                          ("noreaim_vs_grid_min", "no re-aim/grid min", ".2f"),
                          ("ours_coverage_pct", "ours @0.25 m %", ".2f")]))
    parts = sorted(set(args.parts))
    name = "flights" if parts == [1, 2, 3] else "flights_" + "".join(map(str, parts))
    path = write_json(name, args.quick, {"rows": splits, "model_vs_simple": timings, "flying_through": passing})
    print(f"written {path}")


if __name__ == "__main__":
    main()
