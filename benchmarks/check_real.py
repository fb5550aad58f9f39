"""`coverplan check` on the real photo sets in ../shared/data/real-photos, at several working sizes.

Each set is checked as the cameras wrote it against a flat 160 x 160 m target under the photos
(at take-off height for the DJI set: GPS altitude less the relative altitude; for the Canon set,
whose photos give no height above the ground, 300 m: no verdict is expected there, only its
reason). Per set and ``--working-px``: seconds per photo for features, matching and mapping,
photos registered in the largest model, models, the camera centres' distance from their GNSS
tags after alignment, the fit's move and the verdict or why there is none: the surface with a 3D
point within 0.2 m, the most the sparse points could reach, and, where that is under the bar, the
surface the registered photos see twice (the verdict then).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import trimesh

from common import ROOT, table, write_json
from coverplan import load_scene
from coverplan.progress import Progress
from coverplan.sfm.check import check
from coverplan.sfm.photos import photo_files, read_photo

REAL = ROOT.parent / "shared" / "data" / "real-photos"
SETS = {"brighton-beach": None, "caliterra": 300.0}  # ground height, m above sea level (None: from the tags)


def flat_target(folder: Path, half: float = 80.0) -> Path:
    mesh = trimesh.Trimesh([[-half, -half, 0], [half, -half, 0], [half, half, 0], [-half, half, 0]],
                           [[0, 1, 2], [0, 2, 3]])
    path = folder / "flat.ply"
    mesh.export(path)
    return path


def row_for(name: str, ground: float | None, width: int, tmp: Path, first: int | None = None) -> dict:
    folder = REAL / name
    if first is not None:  # the first photos only, copied as they are
        import shutil

        part = tmp / f"{name}_first_{first}"
        part.mkdir(exist_ok=True)
        for f in photo_files(folder)[:first]:
            shutil.copy2(f, part / f.name)
        folder = part
    tags = [read_photo(f) for f in photo_files(folder)]
    lat, lon = float(np.mean([t.lat for t in tags])), float(np.mean([t.lon for t in tags]))
    if ground is None:
        ground = float(np.median([t.gps_altitude_m - t.relative_altitude_m for t in tags]))
    scene = load_scene(flat_target(tmp), geodetic_origin=[lat, lon, ground])
    t = time.perf_counter()
    result = check(folder, scene, tmp / f"{name}_{width}", working_px=width, progress=Progress(bars=False))
    total = time.perf_counter() - t
    sim, n = result.simulation, len(tags)
    return {"set": name, "photos": n, "working_px": width, "features_s_per_photo": sim.seconds["features"] / n,
            "matching_s": sim.seconds["matching"], "mapping_s": sim.seconds["mapping"], "total_s": total,
            "registered": sim.registered, "models": sim.models,
            "residual_median_m": result.gnss_residual_m.get("median"), "fit_m": result.icp_shift_m,
            "fitted": result.fitted, "surface_02_pct": None if result.unjudged else sim.reconstructed_pct,
            "point_ceiling_pct": result.point_ceiling_pct,
            "seen_twice_pct": result.photo_cover.get("pct") if result.thin else None,
            "reconstructable": result.reconstructable, "why_not_judged": result.unjudged or None}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the DJI set's first 6 photos at 480 px")
    parser.add_argument("--widths", nargs="+", type=int, default=[640, 1000, 2000])
    args = parser.parse_args(argv)
    sets = {"brighton-beach": None} if args.quick else SETS
    widths = [480] if args.quick else args.widths
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, ground in sets.items():
            for width in widths:
                rows.append(row_for(name, ground, width, Path(tmp), first=6 if args.quick else None))
                print(f"  {name} at {width} px", flush=True)
    print(table(rows, [("set", "set", ""), ("photos", "photos", "d"), ("working_px", "px", "d"),
                       ("features_s_per_photo", "features s/photo", ".2f"), ("matching_s", "matching s", ".1f"),
                       ("mapping_s", "mapping s", ".1f"), ("registered", "registered", "d"), ("models", "models", "d"),
                       ("residual_median_m", "centre-tag m", ".2f"), ("fit_m", "fit m", ".2f"),
                       ("surface_02_pct", "@0.2 m %", ".1f"), ("point_ceiling_pct", "points' ceiling %", ".1f"),
                       ("seen_twice_pct", "seen twice %", ".1f")]))
    for r in rows:
        if r["why_not_judged"]:
            print(f"{r['set']} at {r['working_px']} px: no verdict: {r['why_not_judged']}")
    print(f"written {write_json('check_real', args.quick, {'rows': rows})}")


if __name__ == "__main__":
    main()
