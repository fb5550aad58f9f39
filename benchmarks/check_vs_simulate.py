"""Does `coverplan check` on a flight's tagged photos say what `simulate` says of the same flight?

The gabled house's default plan without the photos taken north of the house (35 of 47):
`simulate` renders and judges them (ideal conditions, aligned to the true camera centres);
the same photos, rendered by the same renderer and written as JPEGs tagged as a DJI drone
tags them (sfm/photos.py), go through `check` (positions and camera read back from the tags,
aligned through the GNSS tags, fitted to the scene). Prints both verdicts side by side and
writes results/check_vs_simulate.json. Slow (two COLMAP runs): not part of the test suite.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from common import MESHES, write_json
from coverplan import get_camera, load_scene, plan
from coverplan.progress import Progress
from coverplan.sfm.check import check
from coverplan.sfm.photos import write_flight_photos
from coverplan.sfm.simulate import simulate

ORIGIN = [48.77, 9.18, 250.0]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--quick", action="store_true", help="320 px photos")
    args = parser.parse_args(argv)
    width = 320 if args.quick else args.width
    scene = load_scene(MESHES / "gabled_house.obj", geodetic_origin=ORIGIN)
    route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0)
    north = scene.bounds("target")[1][1]
    keep = np.flatnonzero(route.positions[route.shots][:, 1] <= north)
    progress = Progress(verbose=True)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        write_flight_photos(route, scene, tmp / "photos", width=width, shots=keep)
        checked = check(tmp / "photos", scene, tmp / "check", progress=progress).simulation
        route.shot[route.shots[np.setdiff1d(np.arange(len(route.shots)), keep)]] = False
        simulated = simulate(route, scene, tmp / "sim", conditions="ideal", width=width, progress=progress)
    rows = []
    for name, s in (("simulate", simulated), ("check", checked)):
        by = s.surface["by_radius"]
        rows.append({"tool": name, "photos": s.photos, "registered": s.registered, "models": s.models,
                     "surface_01_pct": by["0.1"]["pct"], "surface_02_pct": by["0.2"]["pct"],
                     "by_class_02_pct": by["0.2"]["by_class_pct"]})
    classes = sorted(rows[0]["by_class_02_pct"])
    print(f"{'':9} photos  registered  models  @0.1 m  @0.2 m  " + "  ".join(classes))
    for r in rows:
        print(f"{r['tool']:9} {r['photos']:6d}  {r['registered']:10d}  {r['models']:6d}  {r['surface_01_pct']:6.1f}  "
              f"{r['surface_02_pct']:6.1f}  " + "  ".join(f"{r['by_class_02_pct'][c]:{len(c)}.1f}" for c in classes))
    worst = max(abs(rows[0]["by_class_02_pct"][c] - rows[1]["by_class_02_pct"][c]) for c in classes)
    print(f"largest difference per class @0.2 m: {worst:.1f} pp")
    print("written", write_json("check_vs_simulate", args.quick, {"width_px": width, "rows": rows,
                                                                  "largest_class_difference_pp": worst}))


if __name__ == "__main__":
    main()
