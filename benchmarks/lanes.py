"""Lanes beside shots beside the flights surveyors fly today, on every sample scene.

Each sample scene is planned with ``--selection lanes`` and ``--selection shots`` (Mavic 3
Enterprise, 4 mm/px, 3 m security, flown through) beside QGroundControl's Structure Scan plus
a nadir roof grid at 70/70 overlap, flown through by the same flight-time model and drone:
photos, minutes flown through, smooth steps (consecutive photos within 10 deg of heading and
5 deg of gimbal pitch), reversals per 100 photos, the LP lower bound of the shots' cover, the
evaluator's coverage at 0.25 m and safety (the scan + grid's too: where it misses part of the
building, the ratios flatter it), and planning time (median of ``--repeats`` runs of
each selection in the same process). The field verdict of each selection (worst and median of
its draws, Phantom 4 Pro at 4 mm/px) is read from results/field_proof.json when
``field_proof.py`` has flown the very plan the code makes today. ``--max-pair-deg``,
``--edge-views off`` and ``--reversal-cost`` plan the lanes otherwise than by default (the shots
keep the defaults); the result file's name then says so (``results/lanes_pair50_no_edges_rev24.json``).
"""

from __future__ import annotations

import argparse
import statistics
import time

from common import MESHES, table, write_json
from coverplan import evaluate, get_camera, load_scene, plan
from coverplan.equipment.drones import get_drone
from coverplan.evaluation import view_limits
from coverplan.flight.lanes import route_step_shape
from coverplan.flight.passing import camera_timing, fly_through
from field_proof import CAMERA as FIELD_CAMERA
from field_proof import GSD as FIELD_GSD
from field_proof import SECURITY as FIELD_SECURITY
from field_proof import add_variant_arguments, plan_hash, plan_options, variant, variant_label, verdicts
from field_proof import load as load_field
from plan_scenes import SCENES
from structure_scan import scan_with_roof_grid

GSD, SECURITY = 0.004, 3.0
BARS = {"photos_vs_grid": 0.8, "minutes_vs_grid": 1.0, "smooth_pct": 75.0, "reversals_per_100": 3.0}


def rows_for(name: str, repeats: int, field: list[dict], asked: dict | None = None) -> list[dict]:
    asked = asked or {}
    options = {"lanes": plan_options(**asked), "shots": {}}
    drone = get_drone("m3e")
    model = drone.flight_model()
    timing = camera_timing(drone.camera, drone, model)
    target, obstacles = SCENES[name]
    scene = load_scene(MESHES / target, [MESHES / o for o in obstacles])
    routes, seconds = {}, {}
    for selection in ("lanes", "shots"):
        times = []
        for _ in range(repeats):
            t = time.perf_counter()
            routes[selection] = plan(scene, drone.camera, gsd=GSD, security=SECURITY, drone=drone, max_flight_min=1e6,
                                     selection=selection, **options[selection])
            times.append(time.perf_counter() - t)
        seconds[selection] = statistics.median(times)
    grid = scan_with_roof_grid(scene, drone.camera, GSD, SECURITY, routes["shots"].positions[0])
    grid.params["drone"] = drone.name
    grid_min = fly_through(grid, scene, view_limits(grid, scene), model, **timing)["minutes"]
    grid_photos = int(grid.shot.sum())
    grid_ev = evaluate(grid, scene)  # the peer's own coverage: where it misses, the photo ratio flatters it
    out = []
    for selection, route in routes.items():
        ev = evaluate(route, scene)
        smooth, reversals = route_step_shape(route)
        photos, minutes = int(route.shot.sum()), route.metrics["fly_through"]["minutes"]
        label = selection + (variant_label(**asked) if selection == "lanes" else "")
        row = {"scene": name, "selection": label, "photos": photos, "lane_photos": route.metrics["lane_shots"],
               "grid_photos": grid_photos, "photos_vs_grid": photos / grid_photos, "minutes": minutes,
               "grid_minutes": grid_min, "minutes_vs_grid": minutes / grid_min, "smooth_pct": smooth,
               "grid_smooth_pct": route_step_shape(grid)[0], "grid_coverage_pct": grid_ev.coverage_pct,
               "grid_safe": grid_ev.safe, "reversals_per_100": reversals,
               "lp_bound": route.metrics.get("lp_lower_bound_shots"), "coverage_pct": ev.coverage_pct,
               "safe": ev.safe, "photo_sets": ev.metrics["shot_graph"]["components"], "plan_s": seconds[selection],
               "plan_s_vs_shots": seconds[selection] / seconds["shots"]}
        row["bars_met"] = sum(row[k] <= v if k != "smooth_pct" else row[k] >= v for k, v in BARS.items())
        # The field proof flies the plan at its own settings: its verdicts are this selection's
        # when they were flown on the very plan the code makes today (same hash).
        proved = plan_hash(plan(scene, get_camera(FIELD_CAMERA), gsd=FIELD_GSD, security=FIELD_SECURITY,
                                selection=selection, **options[selection]))
        flown = [v for v in field if v["scene"] == name and v["selection"] == label and v["plan"] == proved]
        if flown:
            row["field_worst_pct"] = min(v["surface_02_pct"] for v in flown)
            row["field_median_pct"] = min(v["median_surface_02_pct"] for v in flown)
            row["field_bar"] = all(v["reconstructable"] for v in flown)
        out.append(row)
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="two scenes, one run each")
    parser.add_argument("--repeats", type=int, default=3)
    add_variant_arguments(parser)
    args = parser.parse_args(argv)
    names = ["square", "gabled"] if args.quick else list(SCENES)
    repeats = 1 if args.quick else args.repeats
    field = verdicts(load_field())
    rows = []
    for name in names:
        rows += rows_for(name, repeats, field, variant(args))
        print(f"  planned {name}", flush=True)
    print(table(rows, [("scene", "scene", ""), ("selection", "selection", ""), ("photos", "photos", "d"),
                       ("lane_photos", "in lanes", "d"), ("photos_vs_grid", "x grid photos", ".2f"),
                       ("minutes", "min", ".1f"), ("minutes_vs_grid", "x grid min", ".2f"),
                       ("smooth_pct", "smooth %", ".0f"), ("grid_smooth_pct", "grid smooth %", ".0f"),
                       ("grid_coverage_pct", "grid cov %", ".1f"), ("grid_safe", "grid safe", ""),
                       ("reversals_per_100", "rev/100", ".1f"), ("lp_bound", "LP bound", ".1f"),
                       ("coverage_pct", "cov %", ".1f"), ("safe", "safe", ""), ("plan_s", "plan s", ".1f"),
                       ("plan_s_vs_shots", "x shots time", ".2f"), ("bars_met", "bars /4", "d"),
                       ("field_worst_pct", "field worst %", ".1f"), ("field_median_pct", "field median %", ".1f")]))
    stem = "lanes" + variant_label(**variant(args)).replace("@", "_pair").replace("-", "_")
    meta = {"gsd_m": GSD, "security_m": SECURITY, "drone": "m3e", **variant(args), "rows": rows}
    print(f"written {write_json(stem, args.quick, meta)}")


if __name__ == "__main__":
    main()
