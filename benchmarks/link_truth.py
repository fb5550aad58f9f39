"""Which photos does COLMAP really match? The planner's link tests against the pairs COLMAP
verified in a field draw.

The planner predicts, from geometry alone, which photo pairs structure-from-motion will match
(``MatchRule.link_test``: ``centroid``, ``faces``, ``samples``), and it builds the plan's one
photo set out of those links. This script flies one field draw of a plan with ``simulate``
(or reads a draw kept earlier, ``--reuse``), reads the inlier counts of every pair COLMAP
verified from its database, and scores each test on the evaluator's samples:

- links it predicts, and how many of them COLMAP verified with fewer than 100 inliers (a
  predicted link that is not there: the plan counts on it, the mapper cannot use it);
- the pairs COLMAP verified with 300 or more inliers that it does not predict (links the plan
  could have counted on);
- the photos left out of the largest model and the predicted links they hung on;
- the same for ``likely``, a wider guess than any link test (``LIKELY``), scored the same way;
- the groups of photos joined through triangles of links (``triangle_groups``), of COLMAP's
  verified pairs and of each test's links: the incremental mapper's models follow the first.

``--quick`` flies the square prism at 8 mm/px and 320 px.
"""

from __future__ import annotations

import argparse
import sqlite3
import tempfile
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from common import MESHES, table, write_json
from coverplan import evaluate, get_camera, load_scene, plan
from coverplan.evaluation import photo_poses
from coverplan.progress import Progress
from coverplan.sfm.simulate import simulate
from coverplan.shots.reconstructability import LINK_TESTS, MatchRule, following_pairs, shot_links
from plan_scenes import SCENES

CAMERA, GSD, SECURITY = "phantom4pro", 0.004, 3.0  # as benchmarks/reconstruction.py
WEAK_INLIERS, STRONG_INLIERS = 100, 300
GROUP_INLIERS = 50  # COLMAP's verified pairs that count as links in its triangle groups
PAIR_ID_BASE = 2147483647  # COLMAP's pair_id = image_id1 * base + image_id2


def verified_inliers(database: Path, n: int) -> np.ndarray:
    """(n, n) inlier counts of the pairs COLMAP verified (photo k is ``shot_%04d``)."""
    with sqlite3.connect(database) as con:
        photo = {i: int(Path(name).stem.split("_")[-1]) for i, name in con.execute("select image_id, name from images")}
        inliers = np.zeros((n, n))
        for pair_id, rows in con.execute("select pair_id, rows from two_view_geometries"):
            b = pair_id % PAIR_ID_BASE
            a = (pair_id - b) // PAIR_ID_BASE
            inliers[photo[a], photo[b]] = inliers[photo[b], photo[a]] = rows
    return inliers


def triangle_groups(adjacency: np.ndarray) -> list[list[int]]:
    """Photos joined through triangles of links that share a side (3-clique communities),
    largest first.

    COLMAP's incremental mapper registers a photo through 3D points that two photos already
    in the model triangulated: it follows a link only where the new photo links to two
    model photos that link to each other. A link with no triangle on it carries nothing.
    """
    a = sp.csr_matrix(np.triu(adjacency, 1) | np.triu(adjacency, 1).T)
    i, j = (x.astype(np.int64) for x in sp.triu(a, 1).nonzero())
    edge = {(int(x), int(y)): k for k, (x, y) in enumerate(zip(i, j))}
    r, c = [], []
    for (x, y), k in edge.items():  # sides of one triangle belong together
        for z in np.intersect1d(a[x].indices, a[y].indices):
            for side in ((min(x, z), max(x, z)), (min(y, z), max(y, z))):
                r.append(k)
                c.append(edge[side])
    m = len(edge)
    joined = sp.coo_matrix((np.ones(len(r)), (r, c)), shape=(m, m))
    _, label = connected_components(joined, directed=False)
    in_triangle = np.zeros(m, dtype=bool)
    in_triangle[r] = True
    groups = {}
    for (x, y), k in edge.items():
        if in_triangle[k]:
            groups.setdefault(label[k], set()).update((x, y))
    return sorted((sorted(g) for g in groups.values()), key=len, reverse=True)


LIKELY = {"incidence_deg": 70.0, "pair_deg": 50.0, "overlap": 0.15, "range_d_opt": 2.0}


def likely_links(route, scene, rule: dict = LIKELY) -> np.ndarray:
    """(n, n) bool: the pairs COLMAP is likely to match, a wider guess than any link test:
    the photos share ``overlap`` of the smaller one's samples (the evaluator's, in frame and
    sight, within ``range_d_opt`` times d_opt) that both see within ``incidence_deg`` of their
    normal and whose rays meet within ``pair_deg``."""
    ev = evaluate(route, scene, rule="thesis")
    cam, pt, rng = ev.pairs
    positions = photo_poses(route)[0]
    n = len(positions)
    ray = positions[cam] - ev.samples.points[pt]
    ray /= np.linalg.norm(ray, axis=1)[:, None]
    square = np.einsum("ij,ij->i", ray, ev.samples.normals[pt]) >= np.cos(np.radians(rule["incidence_deg"]))
    keep = square & (rng <= rule["range_d_opt"] * route.d_opt)
    cam, pt, ray = cam[keep], pt[keep], ray[keep]
    order = np.lexsort((cam, pt))
    cam, pt, ray = cam[order], pt[order], ray[order]
    count = np.bincount(pt, minlength=len(ev.samples))
    later = (np.cumsum(count))[pt] - np.arange(len(pt)) - 1  # the sample's views after this one
    a, b = following_pairs(np.arange(len(pt)), later)
    meet = np.einsum("ij,ij->i", ray[a], ray[b]) >= np.cos(np.radians(rule["pair_deg"]))
    shared = sp.coo_matrix((np.ones(int(meet.sum())), (cam[a[meet]], cam[b[meet]])), shape=(n, n)).toarray()
    shared += shared.T
    size = np.bincount(cam, minlength=n)
    links = shared >= rule["overlap"] * np.maximum(np.minimum(size[:, None], size[None, :]), 1)
    np.fill_diagonal(links, False)
    return links


def largest_model_photos(colmap: Path) -> set[int]:
    import pycolmap

    best: set[int] = set()
    for folder in sorted((colmap / "sparse").iterdir()):
        names = {int(Path(im.name).stem.split("_")[-1]) for im in pycolmap.Reconstruction(folder).images.values()}
        best = max(best, names, key=len)
    return best


def score(route, scene, colmap: Path) -> list[dict]:
    ev = evaluate(route, scene)
    cam, pt, _ = ev.pairs
    positions = photo_poses(route)[0]
    n = len(positions)
    vis = sp.csr_matrix((np.ones(len(cam)), (cam, pt)), shape=(n, len(ev.samples)))
    inliers = verified_inliers(colmap / "database.db", n)
    kept = largest_model_photos(colmap)
    left = np.array(sorted(set(range(n)) - kept), dtype=np.int64)
    iu = np.triu_indices(n, 1)
    real = inliers[iu]
    colmap_groups = [len(g) for g in triangle_groups(inliers >= GROUP_INLIERS)]
    rows = []
    for test in (*LINK_TESTS, "likely"):
        links = likely_links(route, scene) if test == "likely" else shot_links(
            vis, positions, ev.samples.points, MatchRule(link_test=test), normals=ev.samples.normals)
        predicted = links[iu]
        got = real[predicted]
        weak = np.flatnonzero(predicted & (real < WEAK_INLIERS))
        across = [(int(a), int(b), int(inliers[a, b])) for a, b in zip(*np.nonzero(np.triu(links)))
                  if (a in kept) != (b in kept)]
        rows.append({"test": test, "photos": n, "registered": len(kept), "left_out": left.tolist(),
                     "links": int(predicted.sum()), "weak_links": len(weak),
                     "weak": [(int(iu[0][k]), int(iu[1][k]), int(real[k])) for k in weak],
                     "min_inliers": float(got.min()) if len(got) else None,
                     "median_inliers": float(np.median(got)) if len(got) else None,
                     "strong_pairs": int((real >= STRONG_INLIERS).sum()),
                     "strong_missed": int(((real >= STRONG_INLIERS) & ~predicted).sum()),
                     "links_to_left_out": across, "triangle_groups": [len(g) for g in triangle_groups(links)],
                     "colmap_triangle_groups": colmap_groups})
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--scene", default="flush", choices=sorted(SCENES))
    parser.add_argument("--link-test", default="centroid", choices=list(LINK_TESTS), help="the plan's own link test")
    parser.add_argument("--seed", type=int, default=0, help="the field draw's seed")
    parser.add_argument("--width", type=int, default=1024, help="rendered photo width in px")
    parser.add_argument("--reuse", default=None, help="a kept simulate folder of this plan (its colmap/ inside)")
    parser.add_argument("--tag", default=None, help="write results/link_truth_TAG.json")
    args = parser.parse_args(argv)
    gsd = GSD
    if args.quick:  # a smoke run: a coarser GSD flies fewer photos
        args.scene, args.width, args.reuse, gsd = "square", 320, None, 0.008
    target, obstacles = SCENES[args.scene]
    scene = load_scene(MESHES / target, [MESHES / o for o in obstacles])
    route = plan(scene, get_camera(CAMERA), gsd=gsd, security=SECURITY, match=MatchRule(link_test=args.link_test))
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(args.reuse) if args.reuse else Path(tmp) / "draw"
        if not args.reuse:
            simulate(route, scene, out, width=args.width, conditions="field", draws=1, texture="noise",
                     seed=args.seed, progress=Progress(verbose=True))
        colmap = next(out.rglob("database.db")).parent
        rows = score(route, scene, colmap)
    for r in rows:
        r.update({"scene": args.scene, "plan_link_test": args.link_test, "seed": args.seed})
    print(table(rows, [("test", "link test", ""), ("photos", "photos", "d"), ("registered", "largest model", "d"),
                       ("links", "links", "d"), ("weak_links", f"< {WEAK_INLIERS} inliers", "d"),
                       ("min_inliers", "fewest", ".0f"), ("median_inliers", "median", ".0f"),
                       ("strong_pairs", f"pairs >= {STRONG_INLIERS}", "d"), ("strong_missed", "not predicted", "d")]))
    print(f"  COLMAP's verified pairs of {GROUP_INLIERS}+ inliers, triangle groups (photos): "
          f"{rows[0]['colmap_triangle_groups'][:6]}; the tests' links: "
          + "; ".join(f"{r['test']} {r['triangle_groups'][:6]}" for r in rows))
    for r in rows:
        if r["left_out"]:
            print(f"  {r['test']}: photos {r['left_out']} left out; its links to them (a, b, inliers): "
                  f"{r['links_to_left_out']}")
    path = write_json("link_truth" + (f"_{args.tag}" if args.tag else ""), args.quick,
                      {"camera": CAMERA, "gsd_m": gsd, "security_m": SECURITY, "photo_width_px": args.width,
                       "rows": rows})
    print(f"written {path}")


if __name__ == "__main__":
    main()
