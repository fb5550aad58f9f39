"""The field proof, in pieces: each plan flown under field conditions, draw by draw, resumable.

For each sample scene and selection (``--selection shots lanes``), the plan at the settings of
``reconstruction.py`` (Phantom 4 Pro, 4 mm/px, 3 m security) is flown under ``--conditions``
(default field) with each ``--textures`` family, one draw per seed, rendered and reconstructed
by COLMAP (``coverplan.sfm.simulate``, one draw at a time). Every finished draw is written at
once to ``results/field_proof.json`` under a key made of the scene, selection, conditions,
texture, the plan's hash (its waypoints, headings and pitches) and the seed: a rerun skips
what is there, a killed run loses at most the draw in flight, and a changed plan is flown
again. Run it scene by scene (``--scenes gabled``) across sittings; ``--table`` prints the
verdicts stored (worst and median of the draws per plan) without flying anything.
``--max-pair-deg``, ``--edge-views off`` and ``--reversal-cost`` plan the lanes otherwise than
by default (a wider matching rule, no required edge views, another price on reversals); the
variant is part of the key (``lanes@50-no-edges-rev24``), so its draws are kept apart.

The verdict per plan is the worst draw's: registered photos in the largest model, models, the
surface with a 3D point within 0.2 m, overall and of its weakest class (the bar: >= 98 % of
photos in one model, >= 95 % of the surface, >= 90 % of every class).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from common import MESHES, RESULTS, machine, table
from coverplan import get_camera, load_scene, plan
from coverplan.progress import Progress
from coverplan.sfm.simulate import simulate
from coverplan.shots.reconstructability import MatchRule
from plan_scenes import SCENES

CAMERA, GSD, SECURITY = "phantom4pro", 0.004, 3.0
FILE = RESULTS / "field_proof.json"
QUICK_FILE = RESULTS / "field_proof_quick.json"  # --quick: the gabled house, one small draw
DEFAULT_PAIR_DEG = MatchRule().max_pair_deg


def add_variant_arguments(parser: argparse.ArgumentParser) -> None:
    """The options that plan the lanes otherwise than by default (the shots keep the defaults)."""
    parser.add_argument("--max-pair-deg", type=float, default=None,
                        help=f"the matching rule's widest pair (default {DEFAULT_PAIR_DEG:g} deg)")
    parser.add_argument("--edge-views", choices=["on", "off"], default="on",
                        help="off: plan without the required edge views (as coverplan plan --edge-views off)")
    parser.add_argument("--reversal-cost", dest="reversal_steps", type=float, default=None, metavar="STEPS",
                        help="the tour's price on a reversal, in typical steps (default: the planner's)")
    parser.add_argument("--min-cut", type=int, default=None, metavar="LINKS",
                        help="links joining every group of photos to the rest (as coverplan plan --min-cut)")


def variant(args: argparse.Namespace) -> dict:
    """The variant the arguments ask: max_pair_deg, edge_views, reversal_steps, min_cut."""
    return {"max_pair_deg": args.max_pair_deg, "edge_views": args.edge_views == "on",
            "reversal_steps": args.reversal_steps, "min_cut": args.min_cut}


def plan_options(max_pair_deg: float | None = None, edge_views: bool = True,
                 reversal_steps: float | None = None, min_cut: int | None = None) -> dict:
    """The plan() options of a variant (nothing for the defaults)."""
    rule = {k: v for k, v in (("max_pair_deg", max_pair_deg), ("min_cut", min_cut)) if v is not None}
    options = {"match": MatchRule(**rule)} if rule else {}
    if not edge_views:
        options["edge_views"] = False
    if reversal_steps is not None:
        options["reversal_steps"] = reversal_steps
    return options


def variant_label(max_pair_deg: float | None = None, edge_views: bool = True,
                  reversal_steps: float | None = None, min_cut: int | None = None) -> str:
    """The key's part for a variant: empty for the defaults, else e.g. ``@50-no-edges-rev24-cut3``."""
    label = "" if max_pair_deg in (None, DEFAULT_PAIR_DEG) else f"@{max_pair_deg:g}"
    label += "" if edge_views else "-no-edges"
    label += "" if reversal_steps is None else f"-rev{reversal_steps:g}"
    return label + ("" if min_cut in (None, MatchRule().min_cut) else f"-cut{min_cut:d}")


def plan_hash(route) -> str:
    """The plan's identity: its waypoints, headings and pitches, rounded to the millimetre and
    the hundredth of a degree."""
    rows = np.column_stack([np.round(route.positions, 3), np.round(route.heading_deg, 2),
                            np.round(route.pitch_deg, 2), route.shot])
    return hashlib.sha256(np.ascontiguousarray(rows).tobytes()).hexdigest()[:12]


def load(path: Path = FILE) -> dict:
    return json.loads(path.read_text())["draws"] if path.exists() else {}


def save(draws: dict, path: Path = FILE) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps({"machine": machine(), "camera": CAMERA, "gsd_m": GSD, "security_m": SECURITY,
                               "rows": verdicts(draws), "draws": draws}, indent=1))
    tmp.replace(path)  # never a half-written file, whenever the run is stopped
    return path


def verdicts(draws: dict) -> list[dict]:
    """Per plan (scene, selection, conditions, texture, hash): worst and median of its draws."""
    plans: dict[tuple, list] = {}
    for key, d in draws.items():
        label = key.split("|")[1]  # the selection and its variant
        plans.setdefault((d["scene"], label, d["conditions"], d["texture"], d["plan"]), []).append(d)
    rows = []
    for (scene, selection, conditions, texture, h), ds in sorted(plans.items()):
        worst = min(ds, key=lambda d: (d["reconstructable"], d["registered"] / d["photos"], d["surface_02_pct"]))
        rows.append({"scene": scene, "selection": selection, "conditions": conditions, "texture": texture, "plan": h,
                     "draws": len(ds), "photos": worst["photos"], "registered": worst["registered"],
                     "models": worst["models"], "surface_02_pct": worst["surface_02_pct"],
                     "median_surface_02_pct": float(np.median([d["surface_02_pct"] for d in ds])),
                     "weakest_class": worst["weakest_class"], "weakest_class_pct": worst["weakest_class_pct"],
                     "reconstructable": all(d["reconstructable"] for d in ds),
                     "minutes": float(np.sum([d["seconds"] for d in ds])) / 60.0})
    return rows


def fly_draw(route, scene, work: Path, conditions: str, texture: str, seed: int, width: int) -> dict:
    t = time.perf_counter()
    sim = simulate(route, scene, work, width=width, conditions=conditions, draws=1, texture=texture, seed=seed,
                   progress=Progress(verbose=False))
    by = sim.surface["by_radius"]["0.2"]
    weakest = min(by["by_class_pct"], key=by["by_class_pct"].get)
    return {"photos": sim.photos, "registered": sim.registered, "models": sim.models,
            "surface_02_pct": by["pct"], "weakest_class": weakest, "weakest_class_pct": by["by_class_pct"][weakest],
            "reconstructable": bool(sim.reconstructable), "seconds": time.perf_counter() - t}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", default=sorted(SCENES), choices=sorted(SCENES))
    parser.add_argument("--selection", nargs="+", default=["lanes"], choices=["shots", "lanes"])
    parser.add_argument("--conditions", default="field", choices=["field", "harsh"])
    parser.add_argument("--textures", nargs="+", default=["noise", "cells"], choices=["noise", "cells"])
    parser.add_argument("--draws", type=int, default=3)
    parser.add_argument("--width", type=int, default=1024, help="rendered photo width in px")
    add_variant_arguments(parser)
    parser.add_argument("--table", action="store_true", help="print the stored verdicts and fly nothing")
    parser.add_argument("--quick", action="store_true", help="the gabled house's lanes, one draw of 240 px photos")
    args = parser.parse_args(argv)
    path = FILE
    if args.quick:
        args.scenes, args.selection, args.textures, args.draws, args.width = ["gabled"], ["lanes"], ["noise"], 1, 240
        path = QUICK_FILE
        path.unlink(missing_ok=True)
    draws = load(path)
    if not args.table:
        camera = get_camera(CAMERA)
        with tempfile.TemporaryDirectory() as tmp:
            for name in args.scenes:
                target, obstacles = SCENES[name]
                scene = load_scene(MESHES / target, [MESHES / o for o in obstacles])
                for selection in args.selection:
                    asked = variant(args) if selection == "lanes" else {}
                    route = plan(scene, camera, gsd=GSD, security=SECURITY, selection=selection,
                                 **plan_options(**asked))
                    h = plan_hash(route)
                    label = selection + variant_label(**asked)
                    for texture in args.textures:
                        for seed in range(args.draws):
                            key = f"{name}|{label}|{args.conditions}|{texture}|{h}|{seed}"
                            if key in draws:
                                continue
                            row = fly_draw(route, scene, Path(tmp) / key.replace("|", "_"), args.conditions,
                                           texture, seed, args.width)
                            draws[key] = dict(row, scene=name, selection=selection, variant=label,
                                              conditions=args.conditions,
                                              texture=texture, plan=h, seed=seed, width=args.width)
                            save(draws, path)
                            print(f"  {name} {label} {texture} seed {seed}: {row['registered']}/{row['photos']}, "
                                  f"{row['models']} model(s), {row['surface_02_pct']:.1f} % @0.2 m, "
                                  f"{row['weakest_class']} {row['weakest_class_pct']:.1f} % "
                                  f"({row['seconds'] / 60:.1f} min)", flush=True)
    print(table(verdicts(draws), [("scene", "scene", ""), ("selection", "selection", ""),
                                  ("texture", "texture", ""), ("draws", "draws", "d"), ("photos", "photos", "d"),
                                  ("registered", "worst registered", "d"), ("models", "models", "d"),
                                  ("surface_02_pct", "worst @0.2 m %", ".1f"),
                                  ("median_surface_02_pct", "median @0.2 m %", ".1f"),
                                  ("weakest_class", "weakest class", ""), ("weakest_class_pct", "%", ".1f"),
                                  ("reconstructable", "bar met", ""), ("minutes", "sim min", ".1f")]))
    print(f"written {save(draws, path)}")


if __name__ == "__main__":
    main()
