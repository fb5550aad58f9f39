"""Battery flights as one plan, through the command line: evaluate and report take several flight
files (or a pattern) and judge them together, report reads missions, and the report's map shows
each flight in its colour, both flight times, the take-off point, north and a true scale bar
(read back in headless Chromium)."""

from __future__ import annotations

import json
import re
from urllib.parse import parse_qs, urlparse

import numpy as np
import pytest
import trimesh
from pyproj import CRS, Geod, Proj, Transformer

from coverplan.flight.route import Route
from tests.helpers import MESHES
from tests.test_bad_input import assert_one_line_error, run
from tests.test_report import chromium, open_report

RING = str(MESHES / "ring_prism.obj")
GEO = ["--geo-origin", "48.7758", "9.1829", "250"]
JUDGE = ["--camera", "phantom4pro", "--gsd", "0.004", "--security", "3"]


@pytest.fixture(scope="module")
def three_flights(tmp_path_factory):
    """The ring prism planned in flights of at most 8 minutes, exported one QGC plan per flight."""
    import contextlib
    import io

    from coverplan.cli.main import main

    out = tmp_path_factory.mktemp("flights")
    with contextlib.redirect_stdout(io.StringIO()):
        code = main(["plan", RING, "--drone", "phantom4pro", "--gsd", "0.004", "--security", "3", *GEO,
                     "--max-flight-min", "8", "--export", "qgc", "-o", str(out / "ring.json"), "-q"])
    assert code == 0
    route = Route.load(out / "ring.json")
    assert route.n_flights >= 2
    return out, route


def coverage(capsys, *args) -> float:
    code, text, err = run(capsys, "evaluate", *args, "--json")
    assert code == 0, err
    return json.loads(text)["coverage_pct"]


def test_flight_files_are_judged_together(three_flights, capsys):
    out, route = three_flights
    plans = sorted(out.glob("ring.f*.plan"))
    assert len(plans) == route.n_flights
    scene = ["--target", RING, *GEO, *JUDGE]
    whole = coverage(capsys, out / "ring.json")
    together = coverage(capsys, *plans, *scene)
    pattern = coverage(capsys, str(out / "ring.f*.plan"), *scene)
    alone = coverage(capsys, plans[0], *scene)
    assert together == pattern
    assert abs(together - whole) < 0.5, (together, whole)
    assert alone < together - 20.0, (alone, together)


def test_a_pattern_that_matches_nothing_is_one_line(three_flights, tmp_path, capsys):
    out, _ = three_flights
    code, _, err = run(capsys, "evaluate", str(out / "nothing*.plan"), "--target", RING, *GEO, *JUDGE)
    assert_one_line_error(code, err, "matches no file")


def test_report_reads_missions_and_colours_each_flight(three_flights, capsys):
    out, route = three_flights
    code, _, err = run(capsys, "report", str(out / "ring.f*.plan"), "--target", RING, *GEO, *JUDGE,
                       "-o", out / "missions.html")
    assert code == 0, err
    code, _, err = run(capsys, "report", out / "ring.json", "-o", out / "route.html")
    assert code == 0, err
    lo, hi = trimesh.load(RING).bounds
    browser = chromium()
    try:
        for name in ("missions.html", "route.html"):
            open_report(browser, out / name)
            assert not [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
            flights = browser.execute_script(
                "return [...document.querySelectorAll('svg.plan-view polyline.flight')].map(p => p.getAttribute('stroke'))")
            assert len(flights) == route.n_flights and len(set(flights)) == route.n_flights, flights
            swatches = browser.execute_script(
                "return [...document.querySelectorAll('table.flights .swatch')].map(s => s.style.background)")
            assert len(swatches) == route.n_flights
            # the scale bar is true: the target's drawn width, read by the scale bar, is its real width
            svg = browser.find_element("css selector", "svg.plan-view")
            per_px = float(svg.get_attribute("data-scale-m")) / float(svg.get_attribute("data-scale-px"))
            width = browser.execute_script("return document.querySelector('svg.plan-view path.target').getBBox().width")
            assert abs(width * per_px - (hi[0] - lo[0])) < 0.02 * (hi[0] - lo[0]), (width * per_px, hi[0] - lo[0])
        # the route's report: both times, each flight flown through faster than stopping
        browser.get((out / "route.html").as_uri())
        cells = browser.execute_script("return [...document.querySelectorAll('table.flights tr')].slice(1)"
                                       ".map(r => [...r.cells].map(c => c.textContent))")
        for row in cells:
            assert float(row[1]) < float(row[2]), row
        assert [float(r[1]) for r in cells] == pytest.approx(route.metrics["fly_through"]["flight_minutes"], abs=0.06)
        href = browser.find_element("css selector", "a.map-link").get_attribute("href")
        lat, lon = (float(v) for v in parse_qs(urlparse(href).query)["query"][0].split(","))
        east, north = route.positions[0, :2]
        azimuth, _, distance = Geod(ellps="WGS84").inv(9.1829, 48.7758, lon, lat)
        shown = distance * np.array([np.sin(np.radians(azimuth)), np.cos(np.radians(azimuth))])
        assert np.linalg.norm(shown - [east, north]) < 0.3
        headline = browser.find_element("css selector", "header").text
        assert "min flown through" in headline and "stopping at every photo" in headline
    finally:
        browser.quit()


def test_the_north_arrow_follows_the_grid_convergence(tmp_path, capsys):
    """A box placed in UTM zone 32 three degrees east of its central meridian: the map's north
    arrow leans by the meridian convergence pyproj gives there."""
    crs = "EPSG:25832"
    lat, lon = 48.77, 12.0
    x, y = Transformer.from_crs("EPSG:4326", crs, always_xy=True).transform(lon, lat)
    mesh = trimesh.load(MESHES / "square_prism.obj")
    mesh.apply_translation([x, y, 300.0])
    path = tmp_path / "box_utm.obj"
    mesh.export(path)
    code, _, err = run(capsys, "plan", path, *JUDGE, "--crs", crs, "-o", tmp_path / "r.json", "--report",
                       tmp_path / "r.html", "-q")
    assert code == 0, err
    text = (tmp_path / "r.html").read_text()
    nx, ny = (float(v) for v in re.search(r'data-north="([-\d.]+),([-\d.]+)"', text).groups())
    convergence = Proj(CRS(crs)).get_factors(lon, lat).meridian_convergence
    assert abs(convergence) > 2.0
    assert np.degrees(np.arctan2(-nx, ny)) == pytest.approx(convergence, abs=0.05)
