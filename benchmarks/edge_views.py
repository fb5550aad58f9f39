"""What edge views cost: the sample scenes planned with them (``--edge-views on``, the
default) and without (``--edge-views off``).

Field settings (as ``reconstruction.py``: Phantom 4 Pro, 4 mm/px, 3 m security). Per scene and
way: photos and their ratio, the evaluator's photo sets and cut photos on its own samples,
coverage at 0.25 m, safety, and planning time (median of ``--repeats`` runs) and its ratio.
Whether the photos reconstruct is ``reconstruction.py --flights coverplan no-edge-views``'s
question. ``--quick`` plans the square once.
"""

from __future__ import annotations

import argparse

import numpy as np

from common import MESHES, table, timed, write_json
from coverplan import evaluate, get_camera, load_scene, plan
from coverplan.shots.candidates import EDGE_TURN_DEG, EDGE_VIEW_MIN_SHARE, EDGE_VIEW_SPACING
from plan_scenes import SCENES

CAMERA, GSD, SECURITY = "phantom4pro", 0.004, 3.0


def row(name: str, scene, edge_views: bool, repeats: int) -> dict:
    seconds, route = timed(lambda: plan(scene, get_camera(CAMERA), gsd=GSD, security=SECURITY,
                                        edge_views=edge_views), repeats)
    ev = evaluate(route, scene)
    graph = ev.metrics["shot_graph"]
    return {"scene": name, "edge_views": edge_views, "photos": len(route.shots),
            "photo_sets": graph["components"], "cut_photos": graph["cut_shots"],
            "coverage_pct": ev.metrics["coverage_pct"], "safe": bool(ev.metrics["safe"]), "plan_s": seconds}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--scenes", nargs="+", default=None, choices=sorted(SCENES))
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    names = ["square"] if args.quick else (args.scenes or list(SCENES))
    repeats = 1 if args.quick else args.repeats
    rows = []
    for name in names:
        target, obstacles = SCENES[name]
        scene = load_scene(MESHES / target, [MESHES / o for o in obstacles])
        without, with_edges = (row(name, scene, on, repeats) for on in (False, True))
        with_edges["photos_vs_without"] = with_edges["photos"] / without["photos"]
        with_edges["plan_time_vs_without"] = with_edges["plan_s"] / without["plan_s"]
        rows += [without, with_edges]
    print(table(rows, [("scene", "scene", ""), ("edge_views", "edge views", ""), ("photos", "photos", "d"),
                       ("photos_vs_without", "x without", ".2f"), ("photo_sets", "photo sets", "d"),
                       ("cut_photos", "cut photos", "d"), ("coverage_pct", "coverage %", ".1f"),
                       ("safe", "safe", ""), ("plan_s", "plan s", ".1f"),
                       ("plan_time_vs_without", "time x", ".2f")]))
    ratios = [r["photos_vs_without"] for r in rows if r["edge_views"]]
    print(f"photos with edge views: {min(ratios):.2f}-{max(ratios):.2f}x, median {np.median(ratios):.2f}x")
    path = write_json("edge_views", args.quick,
                      {"camera": CAMERA, "gsd_m": GSD, "security_m": SECURITY, "repeats": repeats,
                       "edge_turn_deg": EDGE_TURN_DEG, "edge_view_spacing_frame_widths": EDGE_VIEW_SPACING,
                       "edge_view_min_share": EDGE_VIEW_MIN_SHARE, "rows": rows})
    print(f"written {path}")


if __name__ == "__main__":
    main()
