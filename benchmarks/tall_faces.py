"""Tall, narrow faces under field conditions: the chapel's tower and spire beside its nave.

The chapel (meshes/chapel.obj: an 18 x 8 m nave with its ridge at 10 m, a 4.5 m square tower
of 24 m under a 6 m spire) is planned as ``reconstruction.py`` plans it (Phantom 4 Pro, 4 mm/px,
3 m security) and simulated under ``--conditions`` (default field) for ``--draws`` seeds.
Each draw's largest COLMAP model is aligned to where its photos were taken (as ``simulate``
aligns it) and judged per part of the building and per façade direction: the share of the
surface with a 3D point within 0.2 m. Beside it, from the plan alone: the planned photos that
image each part, the median number of views per sample and the median of each sample's
squarest view (incidence). ``--from DIR`` judges the draws a run kept in DIR instead of
simulating again. Slow (about 7 minutes a draw): not part of the test suite. ``--quick``: one
draw of the chapel planned at 8 mm/px, photos 320 px wide.
"""

from __future__ import annotations

import argparse
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from common import MESHES, table, write_json
from coverplan import get_camera, load_scene, plan
from coverplan.evaluation import view_limits
from coverplan.progress import Progress
from coverplan.sfm.colmap import _aligned, require_pycolmap
from coverplan.sfm.conditions import fly, get_conditions
from coverplan.sfm.judge import judge_classes, judge_samples
from coverplan.sfm.simulate import JUDGE_SPACING_M, photo_names, simulate
from coverplan.shots.reconstructability import MatchRule
from coverplan.shots.sharpness import best_incidence, incidence_deg
from coverplan.shots.visibility import imaging_pairs
from reconstruction import CAMERA, GSD, SECURITY

C = 25.0  # make_meshes.py's centre: the tower spans x in [C - 11.5, C - 7]
NAVE_RIDGE_Z, TOWER_TOP_Z = 10.0, 24.0
PARTS = ("tower below the ridge", "tower above the ridge", "spire", "nave")


def parts_of(points: np.ndarray) -> np.ndarray:
    """The part of the chapel each point (n, 3) lies on."""
    tower = points[:, 0] <= C - 7 + 1e-6
    return np.where(points[:, 2] > TOWER_TOP_Z, PARTS[2],
                    np.where(tower, np.where(points[:, 2] > NAVE_RIDGE_Z, PARTS[1], PARTS[0]), PARTS[3]))


def plan_views(route, scene, samples) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per judge sample: views and squarest incidence (deg, inf unseen); per (camera, sample) pair: its
    camera and sample."""
    rows = route.shots
    limits = view_limits(route, scene)
    cam, pt, _ = imaging_pairs(route.positions[rows], route.heading_deg[rows], route.pitch_deg[rows],
                               route.camera, samples.points, samples.normals, scene.rays, max_range=limits.d_opt,
                               max_incidence_deg=limits.max_incidence_deg)
    inc = incidence_deg(cam, pt, route.positions[rows], samples.points, samples.normals)
    return np.bincount(pt, minlength=len(samples)), best_incidence(pt, inc, len(samples)), cam, pt


def judge_draw(folder: Path, route, conditions: str, seed: int, samples) -> tuple[int, np.ndarray]:
    """Photos in the draw's largest model, and per judge sample its nearest aligned 3D point."""
    from scipy.spatial import cKDTree
    pycolmap = require_pycolmap()
    sparse = folder / "colmap" / "sparse"
    recs = [pycolmap.Reconstruction(m) for m in sorted(sparse.iterdir())]
    best = max(recs, key=lambda r: r.num_reg_images())
    names = photo_names(len(route.shots))
    flown = fly(route, get_conditions(conditions), seed=seed)
    model = _aligned(pycolmap, best, {n: i for i, n in enumerate(names)}, flown.positions)
    if not model.aligned or not len(model.points):
        return len(model.image_names), np.full(len(samples), np.inf)
    return len(model.image_names), cKDTree(model.points).query(samples.points, k=1)[0]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--draws", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--conditions", default="field", choices=["ideal", "field", "harsh"])
    parser.add_argument("--texture", default="noise", choices=["noise", "cells"])
    parser.add_argument("--width", type=int, default=1024)
    parser.add_argument("--from", dest="kept", default=None, help="judge the draws kept in this folder")
    parser.add_argument("--keep", default=None, help="simulate into this folder and keep it (for --from)")
    parser.add_argument("--tag", default=None)
    parser.add_argument("--metering", default="center", choices=["center", "average"],
                        help="the rendered camera's auto exposure (default center, as DJI's cameras meter)")
    parser.add_argument("--framed-views", type=int, default=None, help="the planner's --framed-views (default its own)")
    args = parser.parse_args(argv)
    gsd = GSD
    if args.quick:  # a smoke run: a coarse plan, small photos, one draw
        gsd, args.width, args.draws, args.kept = 0.008, 320, 1, None
    scene = load_scene(MESHES / "chapel.obj")
    match = None if args.framed_views is None else MatchRule(framed_views=args.framed_views)
    route = plan(scene, get_camera(CAMERA), gsd=gsd, security=SECURITY, match=match)
    samples = judge_samples(scene, JUDGE_SPACING_M)
    classes = judge_classes(samples.normals, samples.kind)
    parts = parts_of(samples.points)
    views, best, cam, pt = plan_views(route, scene, samples)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(args.kept or args.keep or Path(tmp) / "chapel")
        if not args.kept:
            cond = replace(get_conditions(args.conditions), metering=args.metering)
            simulate(route, scene, out, width=args.width, conditions=cond, draws=args.draws,
                     texture=args.texture, seed=args.seed, progress=Progress(verbose=True))
        folders = [out] if args.draws == 1 else [out / f"draw-{k + 1}" for k in range(args.draws)]
        judged = [judge_draw(f, route, args.conditions, args.seed + k, samples) for k, f in enumerate(folders)]
    rows = []
    for part in PARTS:
        for c in sorted(set(classes[parts == part])):
            sel = (parts == part) & (classes == c)
            area = float(samples.area[sel].sum())
            if area < 1.0:
                continue
            pct = [100.0 * float(samples.area[sel & (d <= 0.2)].sum()) / area for _n, d in judged]
            rows.append({"part": part, "class": c, "area_m2": area, "photos_seeing": int(len(np.unique(cam[sel[pt]]))),
                         "median_views": float(np.median(views[sel])), "median_best_incidence_deg":
                         float(np.median(best[sel])), "worst_pct": min(pct), "median_pct": float(np.median(pct)),
                         "draw_pct": pct})
    verdicts = []
    for k, (n_reg, d) in enumerate(judged):
        hit = d <= 0.2
        by_class = {c: 100.0 * float(samples.area[hit & (classes == c)].sum() / samples.area[classes == c].sum())
                    for c in sorted(set(classes))}
        verdicts.append({"seed": args.seed + k, "registered": n_reg,
                         "surface_02_pct": 100.0 * float(samples.area[hit].sum() / samples.area.sum()),
                         "by_class_02_pct": by_class, "least_class": min(by_class, key=by_class.get)})
    print(f"chapel, {len(route.shots)} photos, {args.conditions} conditions, {args.texture} textures, "
          f"{args.draws} draws: photos in the largest model {[n for n, _d in judged]}")
    for v in verdicts:
        print(f"  seed {v['seed']}: {v['registered']}/{len(route.shots)} in the largest model, "
              f"{v['surface_02_pct']:.1f} % within 0.2 m, least {v['least_class']} "
              f"{v['by_class_02_pct'][v['least_class']]:.1f} %")
    print(table(rows, [("part", "part", ""), ("class", "class", ""), ("area_m2", "m2", ".0f"),
                       ("photos_seeing", "photos seeing it", "d"), ("median_views", "views", ".0f"),
                       ("median_best_incidence_deg", "squarest view deg", ".1f"),
                       ("worst_pct", "worst @0.2 m %", ".1f"), ("median_pct", "median @0.2 m %", ".1f")]))
    path = write_json("tall_faces" + (f"_{args.tag}" if args.tag else ""), args.quick,
                      {"camera": CAMERA, "gsd_m": gsd, "security_m": SECURITY, "photos": int(len(route.shots)),
                       "conditions": args.conditions, "metering": args.metering, "texture": args.texture,
                       "draws": args.draws,
                       "registered": [n for n, _d in judged], "verdicts": verdicts, "rows": rows})
    print(f"written {path}")


if __name__ == "__main__":
    main()
