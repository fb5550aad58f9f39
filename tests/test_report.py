"""The HTML report in headless Chromium, the PNG figures, and progress output."""

from __future__ import annotations

import shutil
import time

import numpy as np
import pytest

from coverplan import evaluate, load_scene, plan
from coverplan.cli import main
from coverplan.report import write_figures, write_html_report
from tests.helpers import MESHES, gsd_for

CHROME_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--window-size=1300,1000"]


@pytest.fixture(scope="module")
def planned_house():
    from coverplan import get_camera
    camera = get_camera("thesis80")
    scene = load_scene(MESHES / "gabled_house.obj")
    route = plan(scene, camera, gsd=gsd_for(camera, 7.0), security=3.0)
    return scene, route, evaluate(route, scene)


def open_report(browser, path) -> None:
    """Load the report in ``browser`` and wait until its viewer says it is ready (software WebGL
    beside the other tests on two busy cores can take many seconds)."""
    browser.get(path.as_uri())
    for _ in range(1200):
        if browser.execute_script("return window.reportReady === true"):
            break
        time.sleep(0.05)
    assert browser.execute_script("return window.reportReady === true"), "viewer never finished"


def chromium():
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        pytest.skip("selenium is not installed (pip install '.[test]')")
    binary, driver = shutil.which("chromium"), shutil.which("chromedriver")
    if not binary or not driver:
        pytest.skip("Chromium / chromedriver not installed (Debian: apt-get install chromium chromium-driver)")
    opts = webdriver.ChromeOptions()
    for flag in CHROME_FLAGS:
        opts.add_argument(flag)
    opts.binary_location = binary
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(driver), options=opts)


def test_report_renders_in_headless_chromium(planned_house, tmp_path):
    import io

    import matplotlib.image as mpimg

    scene, route, ev = planned_house
    path = write_html_report(route, scene, tmp_path / "house.html", evaluation=ev)
    assert path.stat().st_size < 10e6
    browser = chromium()
    try:
        open_report(browser, path)
        errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
        assert not errors, errors
        rows = browser.execute_script("return document.querySelectorAll('#road-map tbody tr').length")
        assert rows == len(route)
        canvas = browser.find_element("css selector", "#view canvas")
        shot = mpimg.imread(io.BytesIO(canvas.screenshot_as_png), format="png")
        assert shot.shape[0] > 200 and shot.shape[1] > 200
        assert shot[..., :3].std() > 0.02  # drawn, not a blank canvas
        # toggling layers and colouring does not raise
        browser.execute_script("document.querySelector('input[value=gsd]').click();"
                               "document.querySelector('input[data-layer=path]').click();")
        assert not [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    finally:
        browser.quit()


def test_report_is_self_contained(planned_house, tmp_path):
    scene, route, ev = planned_house
    text = write_html_report(route, scene, tmp_path / "r.html", evaluation=ev).read_text()
    assert "http://" not in text.replace("http://www.w3.org", "") and "https://" not in text
    assert text.count("<tr><td>") >= len(route)


def test_png_figures(planned_house, tmp_path):
    import matplotlib.image as mpimg
    scene, route, ev = planned_house
    paths = write_figures(route, scene, tmp_path / "house", evaluation=ev)
    assert [p.name for p in paths] == ["house_overview.png", "house_slices.png", "house_coverage.png"]
    for p in paths:
        img = mpimg.imread(p)
        assert img.shape[0] > 300 and np.asarray(img)[..., :3].std() > 0.05


def test_cli_report_and_verbose_timings(tmp_path, capsys):
    out = tmp_path / "r.json"
    code = main(["plan", str(MESHES / "gabled_house.obj"), "--camera", "phantom4pro", "--gsd", "0.004",
                 "--security", "3", "-o", str(out), "-v", "--report", str(tmp_path / "r.html")])
    captured = capsys.readouterr()
    assert code == 0 and (tmp_path / "r.html").exists()
    for stage in ("visibility matrix", "view selection", "lattice and Dijkstra", "tour"):
        assert f"[coverplan] {stage}:" in captured.err
    assert "written:" in captured.out
    code = main(["report", str(out), "--target", str(MESHES / "gabled_house.obj"), "-o", str(tmp_path / "b.html"),
                 "--plot", str(tmp_path / "b"), "-q"])
    captured = capsys.readouterr()
    assert code == 0 and captured.out == "" and captured.err == ""
    assert (tmp_path / "b.html").exists() and (tmp_path / "b_overview.png").exists()


def test_pictures_frame_the_target_and_its_flight_not_the_tile():
    """A house with a neighbour 300 m off (a city tile's far corner): the overview, the slices
    and the report's first view hold the house and every waypoint, and stop well short of it."""
    from coverplan import get_camera
    from coverplan.report.frame import focus_bounds
    from coverplan.report.html import report_data
    from coverplan.world.scene import scene_from_meshes
    from tests.helpers import box
    scene = scene_from_meshes([box(0, 0, 0, 10, 8, 6)], [box(300, 300, 0, 320, 320, 12)])
    route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0, lp_time_limit=0)
    lo, hi = focus_bounds(route, scene)
    assert np.all(lo <= route.positions.min(axis=0)) and np.all(hi >= route.positions.max(axis=0))
    assert np.all(lo[:2] <= 0) and np.all(hi[:2] >= [10, 8])
    assert np.all(hi[:2] < 100)  # the far neighbour is outside the frame
    data = report_data(route, scene, evaluate(route, scene))
    assert np.linalg.norm(np.array(data["centre"][:2]) - [5, 4]) < 20 and data["radius"] < 100
