"""Regenerate the pictures in docs/ (run: python docs/make_figures.py).

Plans sample scenes with the thesis settings (d_opt 7 m, security 3 m, 80 deg FOV), writes
their PNG figures, and a screenshot of one HTML report when headless Chromium is present.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT / "src"))

from coverplan import evaluate, get_camera, load_scene, plan  # noqa: E402
from coverplan.report import write_figures, write_html_report  # noqa: E402
from coverplan.report.figures import coverage_histogram, overview, slices  # noqa: E402

SCENES = {"ring": ("ring_prism.obj", []), "fig411": ("thesis_prism.obj", ["fig411_obstacles.obj"]),
          "courtyard": ("courtyard.obj", [])}


def screenshot(html: Path, png: Path) -> None:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    for flag in ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                 "--disable-background-networking", "--window-size=1300,900"]:
        opts.add_argument(flag)
    opts.binary_location = shutil.which("chromium")
    browser = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=opts)
    try:
        browser.get(html.as_uri())
        while not browser.execute_script("return window.reportReady === true"):
            time.sleep(0.05)
        browser.save_screenshot(str(png))
    finally:
        browser.quit()


def main():
    camera = get_camera("thesis80")
    gsd = float(camera.gsd_at(7.0))
    for name, (target, obstacles) in SCENES.items():
        scene = load_scene(ROOT / "meshes" / target, [ROOT / "meshes" / o for o in obstacles])
        route = plan(scene, camera, gsd=gsd, security=3.0, start=[0.0, 50.0, 3.0])
        ev = evaluate(route, scene)
        if name == "fig411":
            write_figures(route, scene, HERE / name, evaluation=ev)
            if shutil.which("chromium") and shutil.which("chromedriver"):
                with tempfile.TemporaryDirectory() as tmp:
                    html = write_html_report(route, scene, Path(tmp) / "report.html", evaluation=ev,
                                             title="coverplan flight report: thesis Figure 4.11 scene")
                    screenshot(html, HERE / "report.png")
        else:
            overview(route, scene, HERE / f"{name}_overview.png")
            if name == "ring":
                slices(route, scene, HERE / f"{name}_slices.png")
                coverage_histogram(ev, HERE / f"{name}_coverage.png")
        print(f"{name}: {ev.metrics['shots']} shots, coverage {ev.metrics['coverage_pct']:.2f} %")


if __name__ == "__main__":
    main()
