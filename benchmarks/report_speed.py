"""The HTML report of a ~500-shot plan: file size and time until the 3D view is drawn.

Plans the 50,000-triangle building for a Phantom 4 Pro at 1.7 mm/px with 2 m security
(about 500 shots), writes the report, and opens it three times in headless Chromium,
timing from navigation to the viewer's first frame (``window.reportReady``). ``--quick``
does the same for the gabled house.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import tempfile
import time
from pathlib import Path

from common import MESHES, big_building, table, write_json
from coverplan import evaluate, get_camera, load_scene, plan
from coverplan.report import write_html_report
from coverplan.world.scene import scene_from_meshes

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--window-size=1300,1000"]


def open_times(path: Path, repeats: int) -> list[float] | None:
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        return None
    if not shutil.which("chromium") or not shutil.which("chromedriver"):
        return None
    opts = webdriver.ChromeOptions()
    for flag in FLAGS:
        opts.add_argument(flag)
    opts.binary_location = shutil.which("chromium")
    browser = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=opts)
    times = []
    try:
        for _ in range(repeats):
            browser.get("about:blank")
            t = time.perf_counter()
            browser.get(path.as_uri())
            while not browser.execute_script("return window.reportReady === true"):
                if time.perf_counter() - t > 60:
                    raise RuntimeError("report did not finish drawing in 60 s")
                time.sleep(0.01)
            times.append(time.perf_counter() - t)
    finally:
        browser.quit()
    return times


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    camera = get_camera("phantom4pro")
    if args.quick:
        scene, name, gsd, security = load_scene(MESHES / "gabled_house.obj"), "gabled house", 0.004, 3.0
    else:
        scene, name, gsd, security = scene_from_meshes([big_building(50_000)]), "building50k", 0.0017, 2.0
    route = plan(scene, camera, gsd=gsd, security=security)
    ev = evaluate(route, scene)
    with tempfile.TemporaryDirectory() as tmp:
        path = write_html_report(route, scene, Path(tmp) / "report.html", evaluation=ev)
        size = path.stat().st_size
        times = open_times(path, 3)
    row = {"scene": name, "shots": int(route.shot.sum()), "waypoints": len(route), "samples": len(ev.samples),
           "faces": sum(len(p.mesh.faces) for p in scene.parts), "size_mb": size / 1e6,
           "open_median_s": statistics.median(times) if times else None,
           "open_max_s": max(times) if times else None}
    print(table([row], [("scene", "scene", ""), ("shots", "shots", "d"), ("waypoints", "waypoints", "d"),
                        ("samples", "samples", "d"), ("faces", "faces", "d"), ("size_mb", "size MB", ".2f"),
                        ("open_median_s", "open s (median of 3)", ".2f"), ("open_max_s", "open s (max)", ".2f")]))
    if times is None:
        print("(Chromium or selenium missing: open time not measured)")
    out = write_json("report_speed", args.quick, {"rows": [row]})
    print(f"written {out}")


if __name__ == "__main__":
    main()
