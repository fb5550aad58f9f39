"""Do the photos reconstruct? coverplan's default plan vs QGroundControl's Structure Scan and
the scan plus a nadir roof grid, under ideal, field and harsh conditions.

For each sample scene the flights are planned at the same camera, GSD and security distance,
their photos rendered on the textured scene as a drone would take them and run through COLMAP
(``coverplan.sfm.simulate``); the table gives photos, path, flight time, planning time, photos
registered in the largest model, number of models and the share of the target surface with a
3D point within 0.2 m, overall and per surface class, worst and median of the draws. Also the
thesis's rule (``--rule thesis``), the plan without its pose margin (``--pose-margin none``) and
without its edge views (``--edge-views off``).
Slow (minutes per flight): not part of the test suite. ``--quick`` runs one small scene.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from common import MESHES, table, write_json
from coverplan import evaluate, get_camera, load_scene, plan
from coverplan.progress import Progress
from coverplan.sfm.colmap import SPATIAL_NEIGHBOURS
from coverplan.sfm.simulate import simulate
from coverplan.shots.reconstructability import MatchRule
from plan_scenes import SCENES  # every sample scene; "fig411" is the thesis prism with its obstacle
from structure_scan import scan_with_roof_grid, structure_scan

CAMERA, GSD, SECURITY = "phantom4pro", 0.004, 3.0
SPEED, SHOT_SECONDS = 5.0, 1.0


def flight_minutes(route) -> float:
    return (route.path_length / SPEED + SHOT_SECONDS * len(route.shots)) / 60.0


def run(name, flight, route, scene, plan_s, out: Path, width: int, conditions: str = "field", draws: int = 3,
        texture: str = "noise", seed: int = 0, neighbours: int = SPATIAL_NEIGHBOURS, mapper: str = "auto") -> dict:
    ev = evaluate(route, scene)
    sim = simulate(route, scene, out / f"{name}_{flight}_{conditions}_{texture}", width=width, conditions=conditions,
                   draws=draws, texture=texture, seed=seed, spatial_neighbours=neighbours, mapper=mapper,
                   progress=Progress(verbose=True))
    by = sim.surface["by_radius"]["0.2"]
    drawn = sim.draws or [sim.summary()]
    row = {"scene": name, "flight": flight, "conditions": conditions, "texture": sim.texture, "draws": len(drawn),
           "median_surface_02_pct": float(sorted(d["surface_0.2_pct"] for d in drawn)[len(drawn) // 2]),
           "median_registered": int(sorted(d["registered"] for d in drawn)[len(drawn) // 2]),
           "draw_summaries": drawn,
           "photos": sim.photos, "path_m": route.path_length,
           "flight_min": flight_minutes(route), "plan_s": plan_s, "registered": sim.registered,
           "registered_pct": 100.0 * sim.registered / sim.photos, "models": sim.models, "points": sim.points,
           "surface_01_pct": sim.surface["by_radius"]["0.1"]["pct"], "surface_02_pct": by["pct"],
           "by_class_02_pct": by["by_class_pct"], "worst_class": min(by["by_class_pct"], key=by["by_class_pct"].get),
           "worst_class_pct": min(by["by_class_pct"].values()), "safe": ev.safe,
           "coverage_pct": ev.coverage_pct, "components": ev.metrics["shot_graph"]["components"],
           "reconstructable": sim.reconstructable, "sim_seconds": sim.seconds,
           "first_seed": seed, "spatial_neighbours": neighbours, "mapper": mapper}
    print(f"  {name} {flight}: {sim.registered}/{sim.photos} registered, {sim.models} models, "
          f"{by['pct']:.1f} % @0.2 m", flush=True)
    return row


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--scenes", nargs="+", default=None, choices=sorted(SCENES))
    flights = ["coverplan", "no-margin", "samples-links", "no-edge-views", "structure-scan", "scan+roof-grid",
               "thesis-rule"]
    parser.add_argument("--flights", nargs="+", default=["coverplan", "structure-scan", "scan+roof-grid"],
                        choices=flights)
    parser.add_argument("--conditions", nargs="+", default=["field"], choices=["ideal", "field", "harsh"])
    parser.add_argument("--draws", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0, help="first draw's seed (draws split over runs)")
    parser.add_argument("--neighbours", type=int, default=SPATIAL_NEIGHBOURS,
                        help="spatial matching above 80 photos: nearest photos per photo")
    parser.add_argument("--mapper", default="auto", choices=["auto", "incremental", "global"])
    parser.add_argument("--textures", nargs="+", default=["noise"], choices=["noise", "cells"])
    parser.add_argument("--width", type=int, default=1024, help="rendered photo width in px")
    parser.add_argument("--keep", default=None, help="folder to keep photos and COLMAP files in")
    parser.add_argument("--tag", default=None, help="write results/reconstruction_TAG.json (runs split over sessions)")
    args = parser.parse_args(argv)
    names = ["gabled"] if args.quick else (args.scenes or list(SCENES))
    if args.quick:  # a smoke run: small photos, one field draw, our flight only
        args.width, args.flights, args.draws = 320, ["coverplan"], 1
        args.conditions, args.textures = ["field"], ["noise"]
    camera = get_camera(CAMERA)
    rows = []

    def save(rows):  # after every flight too: a full run takes hours, a stopped one keeps its rows
        for r in rows:
            for other, key in (("structure-scan", "photos_vs_scan"), ("scan+roof-grid", "photos_vs_scan_grid")):
                base = next((s for s in rows if s["scene"] == r["scene"] and s["flight"] == other), None)
                r[key] = r["photos"] / base["photos"] if base else None
        return write_json("reconstruction" + (f"_{args.tag}" if args.tag else ""), args.quick,
                          {"camera": CAMERA, "gsd_m": GSD, "security_m": SECURITY, "photo_width_px": args.width,
                           "rows": rows})

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(args.keep or tmp)
        for name in names:
            target, obstacles = SCENES[name]
            scene = load_scene(MESHES / target, [MESHES / o for o in obstacles])
            t = time.perf_counter()
            ours = plan(scene, camera, gsd=GSD, security=SECURITY)
            ours_s = time.perf_counter() - t
            routes = {"coverplan": lambda: ours,
                      "no-margin": lambda: plan(scene, camera, gsd=GSD, security=SECURITY, pose_margin="none"),
                      "thesis-rule": lambda: plan(scene, camera, gsd=GSD, security=SECURITY, rule="thesis"),
                      "no-edge-views": lambda: plan(scene, camera, gsd=GSD, security=SECURITY, edge_views=False),
                      "samples-links": lambda: plan(scene, camera, gsd=GSD, security=SECURITY,
                                                    match=MatchRule(link_test="samples")),
                      "structure-scan": lambda: structure_scan(scene, camera, GSD, SECURITY, ours.positions[0]),
                      "scan+roof-grid": lambda: scan_with_roof_grid(scene, camera, GSD, SECURITY, ours.positions[0])}
            for flight in args.flights:
                t = time.perf_counter()
                route = routes[flight]()
                made_s = ours_s if flight == "coverplan" else time.perf_counter() - t
                for cond in args.conditions:
                    for texture in (["noise"] if cond == "ideal" else args.textures):
                        rows.append(run(name, flight, route, scene, made_s, out, args.width, cond, args.draws, texture,
                                        args.seed, args.neighbours, args.mapper))
                        save(rows)
    print(table(rows, [("scene", "scene", ""), ("flight", "flight", ""), ("conditions", "conditions", ""),
                       ("texture", "texture", ""), ("photos", "photos", "d"),
                       ("photos_vs_scan", "x scan", ".2f"), ("photos_vs_scan_grid", "x scan+grid", ".2f"),
                       ("path_m", "path m", ".0f"),
                       ("flight_min", "flight min", ".1f"), ("plan_s", "plan s", ".1f"),
                       ("registered", "registered", "d"), ("models", "models", "d"),
                       ("surface_01_pct", "@0.1 m %", ".1f"), ("surface_02_pct", "worst @0.2 m %", ".1f"),
                       ("median_surface_02_pct", "median @0.2 m %", ".1f"),
                       ("worst_class", "worst class", ""), ("worst_class_pct", "worst %", ".1f")]))
    print(f"written {save(rows)}")


if __name__ == "__main__":
    main()
