"""Proof at scale: how the time of ``simulate`` grows with the photo count, up to 1,000 photos.

The courtyard block is planned for a Mavic 3 Enterprise at finer and finer GSD (more photos
each time, the same building), and each flight is simulated under field conditions as a
user with GNSS-tagged photos would reconstruct it: COLMAP's spatial pairs on the photos'
recorded positions, photos rendered at a reduced width with the camera's field of view kept,
COLMAP's global mapper (``--mapper``; the incremental one split a 335-photo flight).
The table gives each stage's time (rendering, features, matching, mapping, judging) and
the verdict (registered, models, surface at 0.2 m, least class); the last
line fits time = a * photos^b per stage. ``--quick`` runs two small flights.

``--remap VARIANT ...`` maps each flight's matches again with COLMAP's global mapper under
changed options (``REMAPS``) and reports the time and verdict of each beside the default's:
where the mapper's time goes, and what cutting it costs.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from common import MESHES, table, write_json
from coverplan import load_scene, plan
from coverplan.equipment.drones import get_drone
from coverplan.progress import Progress
from coverplan.sfm.colmap import MAX_FEATURES, aligned_models, require_pycolmap
from coverplan.sfm.conditions import fly, get_conditions
from coverplan.sfm.judge import judge_samples, reconstructed_surface
from coverplan.sfm.mapping import _map
from coverplan.sfm.simulate import JUDGE_SPACING_M, photo_names, simulate

DRONE, SECURITY = "m3e", 2.0
STAGES = ("render", "features", "matching", "mapping", "judge")
# COLMAP global mapper options tried against its time (--remap): the bundle adjustment rounds,
# the views kept per track, the tracks kept, the views a track needs in global positioning.
REMAPS = {
    "default": {},
    "ba-iterations-1": {"mapper.ba_num_iterations": 1},
    "views-per-track-20": {"mapper.track_max_num_views_per_track": 20},
    "tracks-50000": {"mapper.keep_max_num_tracks": 50_000},
    "positioner-views-6": {"mapper.global_positioning.min_num_view_per_track": 6},
}


def remap(route, scene, folder: Path, variant: str, conditions: str) -> dict:
    """Map the simulated flight in ``folder`` again (its own matches) with the global mapper
    under ``REMAPS[variant]``: seconds, registered photos, models, surface at 0.2 m, and how
    far the registered cameras land from where the photos were taken."""
    pycolmap = require_pycolmap()
    work = folder / f"remap-{variant}"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir()
    shutil.copy(folder / "colmap" / "database.db", work / "database.db")
    t = time.perf_counter()
    recs = _map(pycolmap, "global", work / "database.db", folder / "images", work, -1, 0, lambda n: None,
                overrides=REMAPS[variant])
    seconds = time.perf_counter() - t
    route = route.with_existing_photos()
    centres = fly(route, get_conditions(conditions), seed=0).positions  # simulate's draw (seed 0)
    names = photo_names(len(route.shots))
    models = aligned_models(pycolmap, recs, names, centres)
    best = models[0] if models else None
    aligned = best is not None and best.aligned
    by = reconstructed_surface(judge_samples(scene, JUDGE_SPACING_M),
                               best.points if aligned else np.zeros((0, 3)))["by_radius"]["0.2"]
    least = min(by["by_class_pct"].items(), key=lambda kv: kv[1])
    error = best.centre_error_m(names, centres) if best else {"median": float("nan"), "max": float("nan")}
    return {"variant": variant, "options": REMAPS[variant], "mapping_s": seconds,
            "registered": len(best.image_names) if best else 0, "models": len(models),
            "points": int(len(best.points)) if best else 0, "surface_02_pct": by["pct"], "least_class": least[0],
            "least_class_pct": least[1], "centre_error_median_m": error["median"], "centre_error_max_m": error["max"]}


def growth(photos, seconds) -> float | None:
    """b in seconds = a * photos^b, least squares in log-log; None below two photo counts."""
    photos, seconds = np.asarray(photos, float), np.asarray(seconds, float)
    ok = (photos > 0) & (seconds > 0)
    if len(np.unique(photos[ok])) < 2:
        return None
    return float(np.polyfit(np.log(photos[ok]), np.log(seconds[ok]), 1)[0])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--scene", default="courtyard.obj")
    parser.add_argument("--gsds", type=float, nargs="+", default=[0.004, 0.0025, 0.0014],
                        help="m/px; finer = more photos")
    parser.add_argument("--width", type=int, default=640, help="rendered photo width in px (field of view kept)")
    parser.add_argument("--neighbours", type=int, default=20, help="spatial matching: nearest photos per photo")
    parser.add_argument("--conditions", default="field", choices=["ideal", "field", "harsh"])
    parser.add_argument("--mapper", default="global", choices=["incremental", "global"])
    parser.add_argument("--max-features", type=int, default=MAX_FEATURES,
                        help=f"SIFT features per photo at most (default {MAX_FEATURES}, COLMAP's)")
    parser.add_argument("--keep", default=None, help="folder to keep photos and COLMAP files in")
    parser.add_argument("--tag", default=None, help="write results/simulate_scale_TAG.json (runs split over sessions)")
    parser.add_argument("--remap", nargs="*", default=[], choices=sorted(REMAPS),
                        help="map each flight's matches again with the global mapper under these options")
    args = parser.parse_args(argv)
    if args.quick:
        args.scene, args.gsds, args.width, args.neighbours = "gabled_house.obj", [0.008, 0.006], 320, 12
        args.remap = ["ba-iterations-1"]
    drone = get_drone(DRONE)
    scene = load_scene(MESHES / args.scene)
    rows, remaps = [], []
    name = "simulate_scale" + (f"_{args.tag}" if args.tag else "")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(args.keep or tmp)
        for gsd in args.gsds:
            t = time.perf_counter()
            route = plan(scene, drone.camera, gsd=gsd, security=SECURITY, drone=drone, max_flight_min=1e6)
            plan_s = time.perf_counter() - t
            print(f"  planned {len(route.shots)} photos at {1000 * gsd:.1f} mm/px in {plan_s:.0f} s", flush=True)
            t = time.perf_counter()
            sim = simulate(route, scene, out / f"gsd_{1e4 * gsd:.0f}", conditions=args.conditions, draws=1,
                           width=args.width, exhaustive_limit=0, spatial_neighbours=args.neighbours, mapper=args.mapper,
                           max_features=args.max_features, progress=Progress(bars=True, verbose=True))
            total = time.perf_counter() - t
            c, v = sim.least_class
            row = {"gsd_mm": 1000 * gsd, "photos": sim.photos, "plan_s": plan_s, "total_s": total,
                   "total_min": total / 60.0, **{f"{k}_s": float(sim.seconds.get(k, 0.0)) for k in STAGES},
                   "registered": sim.registered, "models": sim.models, "points": sim.points,
                   "surface_02_pct": sim.reconstructed_pct, "least_class": c, "least_class_pct": v,
                   "reconstructable": sim.reconstructable, "photo_width_px": sim.photo_width_px,
                   "centre_error_median_m": sim.centre_error_m["median"], "centre_error_max_m": sim.centre_error_m["max"],
                   "neighbours": args.neighbours, "max_features": args.max_features, "conditions": sim.conditions, "mapper": args.mapper}
            rows.append(row)
            print(f"  {sim.photos} photos: {total / 60:.1f} min, {sim.registered} registered, {sim.models} models, "
                  f"{sim.reconstructed_pct:.1f} % @0.2 m", flush=True)
            for variant in args.remap:
                again = remap(route, scene, out / f"gsd_{1e4 * gsd:.0f}", variant, args.conditions)
                remaps.append({"gsd_mm": 1000 * gsd, "photos": sim.photos, **again})
                print(f"  remapped ({variant}): {again['mapping_s']:.0f} s, {again['registered']} registered, "
                      f"{again['surface_02_pct']:.1f} % @0.2 m", flush=True)
            write_json(name, args.quick, {"drone": DRONE, "scene": args.scene, "mapper": args.mapper, "rows": rows,
                                          "remaps": remaps})
    fit = {k: growth([r["photos"] for r in rows], [r[f"{k}_s"] for r in rows]) for k in STAGES + ("total",)}
    print(table(rows, [("gsd_mm", "GSD mm", ".1f"), ("photos", "photos", "d"), ("plan_s", "plan s", ".0f"),
                       *[(f"{k}_s", f"{k} s", ".0f") for k in STAGES], ("total_min", "simulate min", ".1f"),
                       ("registered", "registered", "d"), ("models", "models", "d"),
                       ("surface_02_pct", "@0.2 m %", ".1f"), ("least_class", "least class", ""),
                       ("least_class_pct", "least %", ".1f"), ("centre_error_max_m", "worst camera m", ".2f")]))
    if remaps:
        print(table(remaps, [("photos", "photos", "d"), ("variant", "global mapper", ""), ("mapping_s", "mapping s", ".0f"),
                             ("registered", "registered", "d"), ("models", "models", "d"), ("points", "points", "d"),
                             ("surface_02_pct", "@0.2 m %", ".1f"), ("least_class_pct", "least %", ".1f"),
                             ("centre_error_max_m", "worst camera m", ".2f")]))
    if all(b is not None for b in fit.values()):
        print("time ~ photos^b: " + ", ".join(f"{k} {b:.2f}" for k, b in fit.items()))
    path = write_json(name, args.quick, {"drone": DRONE, "scene": args.scene, "photo_width_px": args.width,
                                         "neighbours": args.neighbours, "mapper": args.mapper,
                                         "growth_exponent": fit, "rows": rows, "remaps": remaps})
    print(f"written {path}")


if __name__ == "__main__":
    main()
