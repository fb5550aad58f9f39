"""What a pilot reads and sets, through the command line: the take-off point on the map and in
latitude/longitude, a summary that leads with a pilot's figures, and plan's grouped help."""

from __future__ import annotations

import re
from urllib.parse import parse_qs, urlparse

import numpy as np
import pytest
from pyproj import Geod

from coverplan.flight.route import Route
from tests.helpers import MESHES
from tests.test_bad_input import assert_one_line_error, run

BOX = str(MESHES / "square_prism.obj")
ORIGIN = (48.7758, 9.1829, 250.0)
GEO = ["--geo-origin", *map(str, ORIGIN)]
PLAN = ["--drone", "phantom4pro", "--gsd", "0.004", "--security", "3"]


def rows(text: str) -> dict[str, str]:
    """The summary's rows by label (two spaces or more between label and text)."""
    out = {}
    for line in text.splitlines():
        parts = re.split(r"\s{2,}", line.strip(), maxsplit=1)
        if len(parts) == 2:
            out.setdefault(parts[0], parts[1])
    return out


def local_of(lat: float, lon: float) -> np.ndarray:
    """East and north metres of (lat, lon) from the geodetic origin, by pyproj's geodesic (not
    the project's ENU conversion)."""
    azimuth, _, distance = Geod(ellps="WGS84").inv(ORIGIN[1], ORIGIN[0], lon, lat)
    a = np.radians(azimuth)
    return np.array([distance * np.sin(a), distance * np.cos(a)])


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """One plan taking off from a point given in latitude/longitude, 20 m south-west of the box."""
    from coverplan.cli.main import main

    out = tmp_path_factory.mktemp("pilot")
    lat, lon = 48.77563, 9.18265
    import contextlib
    import io
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        code = main(["plan", BOX, *PLAN, *GEO, "--start-latlon", str(lat), str(lon), "-o", str(out / "r.json"), "-q"])
    assert code == 0
    return out, (lat, lon), Route.load(out / "r.json")


def test_the_flight_takes_off_where_the_latlon_says(planned):
    _, (lat, lon), route = planned
    expected = local_of(lat, lon)
    assert np.linalg.norm(route.positions[0, :2] - expected) < 0.3, (route.positions[0], expected)
    assert np.linalg.norm(route.positions[-1, :2] - expected) < 0.3  # and lands there
    assert route.positions[0, 2] >= 3.0 - 1e-6  # raised to the lowest flight height


def test_the_summary_leads_with_the_pilots_figures(planned, capsys):
    out, (lat, lon), route = planned
    code, text, err = run(capsys, "plan", BOX, *PLAN, *GEO, "--start-latlon", lat, lon, "-o", out / "s.json")
    assert code == 0, err
    summary = rows(text)
    labels = list(summary)
    assert labels[:3] == ["photos", "flight time", "path"], labels
    assert summary["photos"] == str(int(route.shot.sum()))
    assert "min flown through" in summary["flight time"] and "stopping at every photo" in summary["flight time"]
    assert "mm/px asked" in summary["GSD"] and "achieved" in summary["GSD"]
    low, high = (float(v) for v in re.findall(r"([\d.]+) to ([\d.]+) m", summary["height above ground"])[0])
    above = route.above_ground()
    assert abs(low - above.min()) < 0.06 and abs(high - above.max()) < 0.06
    # the take-off point in latitude/longitude and a map link that opens it, both where it was asked
    shown = [float(v) for v in re.findall(r"([\d.]+) [NS], ([\d.]+) [EW]", summary["take-off"])[0]]
    assert Geod(ellps="WGS84").inv(lon, lat, shown[1], shown[0])[2] < 0.3
    query = parse_qs(urlparse(summary["on the map"]).query)["query"][0]
    map_lat, map_lon = (float(v) for v in query.split(","))
    assert Geod(ellps="WGS84").inv(lon, lat, map_lon, map_lat)[2] < 0.3
    assert "closest approach" in summary and "photo sets" in summary
    for internal in ("LP lower bound", "d_opt / standoff", "p-outliers", "bisector"):
        assert internal not in text
    code, verbose, _ = run(capsys, "plan", BOX, *PLAN, *GEO, "-o", out / "v.json", "-v")
    assert code == 0 and "LP lower bound" in verbose and "d_opt / standoff" in verbose


def test_without_a_georeference_the_takeoff_is_in_model_coordinates(tmp_path, capsys):
    code, text, err = run(capsys, "plan", BOX, *PLAN, "-o", tmp_path / "r.json")
    assert code == 0, err
    takeoff = rows(text)["take-off"]
    route = Route.load(tmp_path / "r.json")
    x, y = (float(v.replace(",", "")) for v in re.findall(r"x ([-\d.,]+), y ([-\d.,]+)", takeoff)[0])
    assert np.allclose([x, y], route.positions[0, :2], atol=0.01)
    assert "no georeference" in takeoff and "on the map" not in text


@pytest.mark.parametrize("extra, words", [
    (["--start-latlon", "48.7757", "9.1828"], ["--start-latlon needs a georeferenced scene"]),
    ([*GEO, "--start-latlon", "9.1828", "48.7757"], ["km from the target", "latitude first"]),
    ([*GEO, "--start-latlon", "148.7", "9.18"], ["latitude must be within"]),
    ([*GEO, "--start-latlon", "48.7757"], ["LAT LON [H]"]),
    ([*GEO, "--start-latlon", "48.7757", "9.1828", "--start", "0", "0", "0"], ["not both"]),
])
def test_a_bad_takeoff_latlon_is_one_line(tmp_path, capsys, extra, words):
    code, _, err = run(capsys, "plan", BOX, *PLAN, *extra, "-o", tmp_path / "r.json")
    assert_one_line_error(code, err, *words)


def test_plan_help_is_grouped_and_simulate_keeps_its_own_options(capsys):
    code, text, _ = run(capsys, "plan", "--help")
    assert code == 0
    headings = [line[:-1] for line in text.splitlines() if re.match(r"^[a-z][^ ].*:$", line)]
    assert headings[:1] == ["options"] and {"scene", "camera and drone", "quality", "safety and airspace", "flight",
                                            "outputs and exports"} <= set(headings)
    assert text.count("usage:") == 1  # printed once
    for option in ("--photo-width", "--draws", "--conditions", "--max-features"):
        assert option not in text
    code, text, _ = run(capsys, "simulate", "--help")
    assert code == 0 and "--photo-width" in text and "--draws" in text
