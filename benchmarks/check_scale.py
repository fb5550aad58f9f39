"""`coverplan check` at the size of a real flight: a folder of 1,000+ photos, end to end on this machine.

The courtyard block planned for a Mavic 3 Enterprise (2 m security) at 1.4 mm/px (1,072 photos),
rendered once and written as the drone writes its photos (JPEG, EXIF GPS, DJI XMP: sfm/photos.py)
into ``--keep`` (reused on a rerun, so a killed run loses only the check), then checked with
``check``'s defaults (spatial matching on the GNSS tags, 50 neighbours, the mapper picked by size)
exactly as ``coverplan check`` runs. Prints each stage's time, the peak memory of the process
(COLMAP runs inside it) and the verdict; writes results/check_scale.json, one row per
``--neighbours`` (a rerun replaces its own row and keeps the others). With ``--keep``, a rerun
with other neighbours keeps the features the earlier run found (check resumes).
``--quick``: the gabled house at 8 mm/px.
"""

from __future__ import annotations

import argparse
import json
import resource
import tempfile
import time
from pathlib import Path

from common import MESHES, result_path, write_json
from coverplan import load_scene, plan
from coverplan.equipment.drones import get_drone
from coverplan.progress import Progress
from coverplan.sfm.check import check
from coverplan.sfm.colmap import SPATIAL_NEIGHBOURS
from coverplan.sfm.photos import photo_files, write_flight_photos

ORIGIN = [48.77, 9.18, 250.0]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--gsd", type=float, default=0.0014, help="m/px (1.4 mm/px: 1,072 photos)")
    parser.add_argument("--width", type=int, default=480, help="the written photos' width, px")
    parser.add_argument("--neighbours", type=int, default=SPATIAL_NEIGHBOURS,
                        help="spatial matching's neighbours per photo (check's default)")
    parser.add_argument("--keep", default=None, help="folder for the photos and the check (reused by a rerun)")
    args = parser.parse_args(argv)
    mesh, drone_name, security = "courtyard.obj", "m3e", 2.0
    if args.quick:
        mesh, drone_name, security, args.gsd, args.width = "gabled_house.obj", "phantom4pro", 3.0, 0.008, 240
    drone = get_drone(drone_name)
    scene = load_scene(MESHES / mesh, geodetic_origin=ORIGIN)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(args.keep or tmp)
        photos = out / "photos"
        t = time.perf_counter()
        route = plan(scene, drone.camera, gsd=args.gsd, security=security, drone=drone, max_flight_min=1e6)
        plan_s = time.perf_counter() - t
        t = time.perf_counter()
        if not photos.exists() or len(photo_files(photos)) != len(route.shots):
            progress = Progress(bars=True)
            with progress.stage("writing the photos", total=len(route.shots), unit="img") as tick:
                write_flight_photos(route, scene, photos, width=args.width, progress=tick)
        write_s = time.perf_counter() - t
        print(f"{len(route.shots)} photos: planned in {plan_s:.0f} s, written in {write_s:.0f} s", flush=True)
        t = time.perf_counter()
        result = check(photos, scene, out / "check", spatial_neighbours=args.neighbours,
                       progress=Progress(bars=True, verbose=True))
        check_s = time.perf_counter() - t
    peak_gb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20
    sim = result.simulation
    row = {"scene": mesh, "gsd_mm": 1000 * args.gsd, "photos": sim.photos, "width_px": args.width,
           "neighbours": args.neighbours,
           "write_s": write_s, **{f"{k}_s": float(v) for k, v in sim.seconds.items()},
           "check_s": check_s, "check_min": check_s / 60.0, "peak_memory_gb": peak_gb,
           "registered": sim.registered, "models": sim.models, "mapper": sim.mapper,
           "surface_02_pct": sim.surface["by_radius"]["0.2"]["pct"],
           "gnss_residual_median_m": result.gnss_residual_m.get("median")}
    print(f"{'photos':>6}  {'features s':>10}  {'matching s':>10}  {'mapping s':>9}  {'check min':>9}  "
          f"{'peak GB':>7}  {'registered':>10}  models  @0.2 m %")
    print(f"{row['photos']:6d}  {row.get('features_s', 0):10.0f}  {row.get('matching_s', 0):10.0f}  "
          f"{row.get('mapping_s', 0):9.0f}  {row['check_min']:9.1f}  {peak_gb:7.2f}  {row['registered']:10d}  "
          f"{row['models']:6d}  {row['surface_02_pct']:8.1f}")
    print("written", write_json("check_scale", args.quick, {"rows": merged_rows("check_scale", args.quick, row)}))


def merged_rows(name: str, quick: bool, row: dict) -> list[dict]:
    """The rows already in results/NAME.json, with ``row`` in place of one measured alike."""
    path = result_path(name, quick)
    same = ("scene", "gsd_mm", "width_px", "neighbours")
    try:
        rows = json.loads(path.read_text())["rows"]
    except (OSError, ValueError, KeyError):
        rows = []
    rows = [r for r in rows if any(r.get(k) != row[k] for k in same)] + [row]
    return sorted(rows, key=lambda r: -r.get("neighbours", SPATIAL_NEIGHBOURS))


if __name__ == "__main__":
    main()
