"""Bridging the camera's turns with photos in passing: what it costs and what it does (issue 33).

The lanes bar asks for 75 % smooth steps (consecutive photos within 10 deg of heading and
5 deg of gimbal pitch); no order of the default plans' photos reaches it on most scenes
(``smooth_ceiling.py``). The way priced there: keep the plan's photos and order, and on every
straight leg between two photos whose camera turns by at most ``--max-turn`` deg of heading
(half that of pitch) add photos in passing, evenly along the leg and in orientation, so that
each step turns at most 10 deg and 5 deg. A leg is bridged only where its parts can be a metre
long (each then keeps the turn points that hold the camera still at its photos): a bridge cut
short would only turn the steps it has into more steps that are not smooth. The planner's own
turn points, pass plan (blur, photo interval, turning) and final safety check then run on the
bridged waypoints as on any plan (the bridging is put in front of ``add_turn_points``).

Part 1: every sample scene as ``flights.py`` part 3 plans it (Mavic 3 Enterprise, 4 mm/px,
3 m): photos, smooth steps, reversals per 100 photos and minutes flown through, the default
plan beside the bridged one, the scan + roof grid flown through by the same model and drone,
and the bridged plan's coverage re-checked by the evaluator.
Part 2 (``--field S ...``): field simulates of the bridged plans as ``reconstruction.py``
plans them (Phantom 4 Pro, 4 mm/px, 3 m), ``--seed`` and ``--conditions`` as there; with
``--unbridged --min-views N``, of plans that take more photos the planner's way instead, as
a control (is it the photos' number or their small steps?).
Nothing here changes the planner.
"""

from __future__ import annotations

import argparse
import tempfile
from contextlib import contextmanager, nullcontext
from pathlib import Path

import numpy as np

from common import MESHES, table, write_json
from coverplan import evaluate, get_camera, load_scene, plan, simulate
from coverplan.equipment.drones import get_drone
from coverplan.evaluation import view_limits
from coverplan.flight.lanes import route_step_shape
from coverplan.flight.passing import camera_timing, fly_through
from coverplan.flight.route import Route
from coverplan.flight.turning import MIN_LEG_M
from coverplan.geometry.orientation import heading_change_deg
from coverplan.planning import assembly
from coverplan.runs import run_offsets
from coverplan.sfm.colmap import SPATIAL_NEIGHBOURS
from plan_scenes import SCENES
from smooth_ceiling import bridging_photos
from structure_scan import scan_with_roof_grid

MAX_TURN_DEG = 60.0


def bridge_turns(route: Route, max_turn_deg: float) -> Route:
    """``route`` with photos in passing on the straight legs between photos whose camera turns
    by at most ``max_turn_deg`` of heading (half of it of pitch)."""
    p, h, g, shot = route.positions, route.heading_deg, route.pitch_deg, route.shot
    if len(p) < 2:
        return route
    turn, tilt = heading_change_deg(h[:-1], h[1:]), np.diff(g)
    length = np.linalg.norm(np.diff(p, axis=0), axis=1)
    need = bridging_photos(h, g)
    room = np.floor(length / MIN_LEG_M) - 1
    leg = (shot[:-1] & shot[1:] & (route.flight[:-1] == route.flight[1:]) & (np.abs(turn) <= max_turn_deg)
           & (np.abs(tilt) <= max_turn_deg / 2) & (room >= need))  # half a bridge leaves only turns
    count = np.where(leg, need, 0).astype(np.int64)
    legs = np.flatnonzero(count)
    if not len(legs):
        return route
    per = count[legs]
    k = np.repeat(legs, per)
    t = ((run_offsets(per) + 1) / np.repeat(per + 1, per))[:, None]
    where = k + 1
    new_p = p[k] + t * (p[k + 1] - p[k])
    new_h = (h[k] + t[:, 0] * turn[k]) % 360.0
    new_g = g[k] + t[:, 0] * tilt[k]
    ground = None
    if route.ground_z is not None:
        z = route.ground_z
        ground = np.insert(z, where, z[k] + t[:, 0] * (z[k + 1] - z[k]))
    kind = np.array(route.leg, dtype=object)
    return Route(np.insert(p, where, new_p, axis=0), np.insert(shot, where, True), np.insert(h, where, new_h),
                 np.insert(g, where, new_g), np.insert(kind, where, kind[where]).tolist(), route.camera, route.params,
                 frame=route.frame, uncovered=route.uncovered, metrics=route.metrics, extra=route.extra,
                 flight=np.insert(route.flight, where, route.flight[where]), ground_z=ground)


@contextmanager
def bridged_planner(max_turn_deg: float):
    """plan() with the bridging in front of its turn points."""
    original = assembly.add_turn_points
    assembly.add_turn_points = lambda route, share: original(bridge_turns(route, max_turn_deg), share)
    try:
        yield
    finally:
        assembly.add_turn_points = original


def same_photos(bridged: Route, default: Route) -> bool:
    """Every photo of ``default`` is one of ``bridged``'s, at the same pose."""
    a = np.column_stack([default.positions, default.heading_deg, default.pitch_deg])[default.shot]
    b = np.column_stack([bridged.positions, bridged.heading_deg, bridged.pitch_deg])[bridged.shot]
    return all(np.abs(b - row).max(axis=1).min() < 1e-9 for row in a)


def cost_rows(names, max_turn_deg: float, gsd: float = 0.004, security: float = 3.0) -> list[dict]:
    drone = get_drone("m3e")
    model = drone.flight_model()
    timing = camera_timing(drone.camera, drone, model)
    rows = []
    for name in names:
        target, obstacles = SCENES[name]
        scene = load_scene(MESHES / target, [MESHES / o for o in obstacles])
        default = plan(scene, drone.camera, gsd=gsd, security=security, drone=drone, max_flight_min=1e6)
        with bridged_planner(max_turn_deg):
            bridged = plan(scene, drone.camera, gsd=gsd, security=security, drone=drone, max_flight_min=1e6)
        grid = scan_with_roof_grid(scene, drone.camera, gsd, security, default.positions[0])
        grid.params["drone"] = drone.name
        grid_min = fly_through(grid, scene, view_limits(grid, scene), model, **timing)["minutes"]
        row = {"scene": name, "scan_grid_min": grid_min, "same_photos": same_photos(bridged, default)}
        for key, route in (("default", default), ("bridged", bridged)):
            smooth, reverse = route_step_shape(route)
            through = route.metrics["fly_through"]
            row.update({f"{key}_photos": int(route.shot.sum()), f"{key}_smooth_pct": smooth,
                        f"{key}_reversals_per_100": reverse, f"{key}_min": through["minutes"],
                        f"{key}_passing_pct": 100.0 * through["photos_in_passing"] / through["photos"]})
        ev = evaluate(bridged, scene)
        row.update({"bridged_coverage_pct": ev.coverage_pct, "bridged_safe": ev.safe,
                    "photos_x": row["bridged_photos"] / row["default_photos"],
                    "minutes_x": row["bridged_min"] / row["default_min"],
                    "bridged_vs_grid_min": row["bridged_min"] / grid_min})
        rows.append(row)
        print(f"  planned {name}", flush=True)
    return rows


def field_rows(names, max_turn_deg: float, conditions: str, seed: int, neighbours: int, out: Path,
               bridge: bool = True, options: dict | None = None) -> list[dict]:
    camera = get_camera("phantom4pro")
    rows = []
    for name in names:
        target, obstacles = SCENES[name]
        scene = load_scene(MESHES / target, [MESHES / o for o in obstacles])
        with bridged_planner(max_turn_deg) if bridge else nullcontext():
            route = plan(scene, camera, gsd=0.004, security=3.0, **(options or {}))
        sim = simulate(route, scene, out / f"{name}_{conditions}", conditions=conditions, draws=1, seed=seed,
                       spatial_neighbours=neighbours)
        by = sim.surface["by_radius"]["0.2"]
        rows.append({"scene": name, "bridged": bridge, **(options or {}), "conditions": conditions, "seed": seed,
                     "photos": sim.photos,
                     "registered": sim.registered, "models": sim.models, "surface_02_pct": by["pct"],
                     "worst_class": min(by["by_class_pct"], key=by["by_class_pct"].get),
                     "worst_class_pct": min(by["by_class_pct"].values()), "smooth_pct": route_step_shape(route)[0]})
        print(f"  {name}: {sim.registered}/{sim.photos} registered, {sim.models} models, {by['pct']:.1f} % @0.2 m",
              flush=True)
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="part 1 on the square prism only")
    parser.add_argument("--max-turn", type=float, default=MAX_TURN_DEG)
    parser.add_argument("--field", nargs="*", default=[], help="scenes for part 2")
    parser.add_argument("--conditions", default="field", choices=["field", "harsh"])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--neighbours", type=int, default=SPATIAL_NEIGHBOURS)
    parser.add_argument("--no-cost", action="store_true", help="part 2 only")
    parser.add_argument("--unbridged", action="store_true",
                        help="part 2 on the plans as planned (a control: with --min-views, more photos, not bridged)")
    parser.add_argument("--min-views", type=int, default=None, help="part 2: the plans' min_views")
    parser.add_argument("--tag", default="")
    args = parser.parse_args(argv)
    names = ["square"] if args.quick else list(SCENES)
    rows = [] if args.no_cost else cost_rows(names, args.max_turn)
    if rows:
        print(table(rows, [("scene", "scene", ""), ("default_photos", "photos", "d"),
                           ("bridged_photos", "bridged", "d"), ("photos_x", "x", ".2f"),
                           ("default_smooth_pct", "smooth %", ".0f"), ("bridged_smooth_pct", "bridged %", ".0f"),
                           ("default_reversals_per_100", "rev/100", ".1f"),
                           ("bridged_reversals_per_100", "bridged rev/100", ".1f"),
                           ("default_min", "min", ".2f"), ("bridged_min", "bridged min", ".2f"),
                           ("scan_grid_min", "scan+grid min", ".2f"), ("bridged_vs_grid_min", "bridged/grid", ".2f"),
                           ("bridged_passing_pct", "in passing %", ".0f"),
                           ("bridged_coverage_pct", "@0.25 m %", ".2f"), ("bridged_safe", "safe", ""),
                           ("same_photos", "keeps photos", "")]))
    field = []
    if args.field:
        with tempfile.TemporaryDirectory() as tmp:
            options = {} if args.min_views is None else {"min_views": args.min_views}
            field = field_rows(args.field, args.max_turn, args.conditions, args.seed, args.neighbours, Path(tmp),
                               bridge=not args.unbridged, options=options)
        print(table(field, [("scene", "scene", ""), ("bridged", "bridged", ""), ("conditions", "conditions", ""),
                            ("seed", "seed", "d"),
                            ("photos", "photos", "d"), ("registered", "registered", "d"), ("models", "models", "d"),
                            ("surface_02_pct", "@0.2 m %", ".1f"), ("worst_class", "worst class", ""),
                            ("worst_class_pct", "worst %", ".1f"), ("smooth_pct", "smooth %", ".0f")]))
    payload = {"max_turn_deg": args.max_turn, "rows": rows, "field": field}
    print(f"written {write_json('bridging' + args.tag, args.quick, payload)}")


if __name__ == "__main__":
    main()
