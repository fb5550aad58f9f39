"""Does `coverplan check` on a flight's tagged photos say what `simulate` says of the same flight?

The gabled house's default plan (Phantom 4 Pro) without the photos taken north of the house:
`simulate` renders and judges them (ideal conditions, aligned to the true camera centres, the
lens known exactly); the same photos, rendered by the same renderer and written as JPEGs
tagged as a DJI drone tags them (sfm/photos.py, EXIF only: no DewarpData), go through `check`
(positions and camera read back from the tags, the lens estimated in bundle adjustment,
aligned through the GNSS tags, fitted to the scene). ``--lens drone`` draws both through the
drone's raw lens. Prints both verdicts side by side and writes results/check_vs_simulate.json
(``--lens drone``: check_vs_simulate_lens.json). Slow (two COLMAP runs): not in the test suite.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from common import MESHES, write_json
from coverplan import get_camera, load_scene, plan
from coverplan.equipment.drones import get_drone
from coverplan.progress import Progress
from coverplan.sfm.cameras import LENS_MODEL, LENS_MODELS
from coverplan.sfm.check import check
from coverplan.sfm.photos import write_flight_photos
from coverplan.sfm.simulate import photo_lens, simulate

ORIGIN = [48.77, 9.18, 250.0]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--quick", action="store_true", help="320 px photos")
    parser.add_argument("--gsd", type=float, default=0.004, help="the plan's detail, m/px (0.0013: 150+ photos)")
    parser.add_argument("--lens", choices=("pinhole", "drone"), default="pinhole",
                        help="photos drawn through a pinhole or the Phantom 4 Pro's raw lens")
    parser.add_argument("--lens-model", choices=tuple(LENS_MODELS), nargs="+", default=[LENS_MODEL],
                        help="the distortion check estimates (several: one check each, on the same photos)")
    parser.add_argument("--keep", metavar="DIR", help="render the photos into DIR once and reuse them")
    args = parser.parse_args(argv)
    width = 320 if args.quick else args.width
    scene = load_scene(MESHES / "gabled_house.obj", geodetic_origin=ORIGIN)
    drone = get_drone("phantom4pro") if args.lens == "drone" else None  # the lens is the drone profile's
    route = plan(scene, get_camera("phantom4pro"), gsd=args.gsd, security=3.0, drone=drone)
    north = scene.bounds("target")[1][1]
    keep = np.flatnonzero(route.positions[route.shots][:, 1] <= north)
    progress = Progress(verbose=True)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        photos = Path(args.keep) if args.keep else tmp / "photos"
        if not (photos.is_dir() and any(photos.iterdir())):
            write_flight_photos(route, scene, photos, width=width, shots=keep,
                                lens=photo_lens(args.lens, route), dewarp_data=False)
        rows = []
        for model in args.lens_model:
            checked = check(photos, scene, tmp / f"check-{model}", lens_model=model, progress=progress).simulation
            rows.append(_row(f"check ({model})", checked))
            print(rows[-1], flush=True)
        route.shot[route.shots[np.setdiff1d(np.arange(len(route.shots)), keep)]] = False
        simulated = simulate(route, scene, tmp / "sim", conditions="ideal", width=width,
                             lens=args.lens, progress=progress)
        rows.insert(0, _row("simulate", simulated))
    classes = sorted(rows[0]["by_class_02_pct"])
    print(f"{'':22} photos  registered  models  @0.1 m  @0.2 m  " + "  ".join(classes))
    for r in rows:
        print(f"{r['tool']:22} {r['photos']:6d}  {r['registered']:10d}  {r['models']:6d}  {r['surface_01_pct']:6.1f}  "
              f"{r['surface_02_pct']:6.1f}  " + "  ".join(f"{r['by_class_02_pct'][c]:{len(c)}.1f}" for c in classes))
    for r in rows[1:]:
        r["largest_class_difference_pp"] = max(abs(rows[0]["by_class_02_pct"][c] - r["by_class_02_pct"][c])
                                               for c in classes)
        r["overall_difference_pp"] = abs(rows[0]["surface_02_pct"] - r["surface_02_pct"])
        print(f"{r['tool']}: difference overall @0.2 m {r['overall_difference_pp']:.1f} pp, "
              f"largest per class {r['largest_class_difference_pp']:.1f} pp")
    name = "check_vs_simulate" + ("_lens" if args.lens == "drone" else "")
    print("written", write_json(name, args.quick, {"width_px": width, "gsd_m": args.gsd, "lens": args.lens,
                                                   "rows": rows}))


def _row(tool: str, s) -> dict:
    by = s.surface["by_radius"]
    return {"tool": tool, "photos": s.photos, "registered": s.registered, "models": s.models,
            "surface_01_pct": by["0.1"]["pct"], "surface_02_pct": by["0.2"]["pct"],
            "by_class_02_pct": by["0.2"]["by_class_pct"]}


if __name__ == "__main__":
    main()
