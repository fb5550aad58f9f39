"""Keep-out and keep-in zones (issue 34): a city-model house with the street kept out, then
with the property kept in. Every claim is checked on the route file's own waypoints with
shapely on the polygons the test wrote, not with the planner's zone code; the exported
geofence is read back by MAVSDK's own QGroundControl importer and uploaded over MAVLink."""

from __future__ import annotations

import json

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from pyproj import Transformer

from coverplan import evaluate, get_camera, load_scene, plan
from coverplan.cli import main
from coverplan.flight.route import Route
from coverplan.io.zones import read_zones
from coverplan.world.zones import Zone, Zones
from tests.helpers import MESHES, mavsdk_upload

CITY = MESHES / "citygml" / "lod2_buildings_v2.json.gz"
HOUSE = "FZK_GUID_1F3E679D-E226-4535-926C-7390977FB25A"  # 6 x 8 m, 11 m ridge, corner at (0, 0)
PLAN = ["--camera", "phantom4pro", "--gsd", "0.004", "--security", "3"]
STREET_X = 9.0  # the street starts 3 m east of the house's east wall (x = 6), closer than security + margin
FENCE_INCLUSION, FENCE_EXCLUSION = 5001, 5002


def _polygon_file(path, scene, ring_local, name, wgs84=False, **properties):
    """A GeoJSON zone over ``ring_local`` (local x, y), in the models' CRS or in WGS84."""
    ring = scene.to_source(np.column_stack([ring_local, np.zeros(len(ring_local))]))[:, :2]
    doc = {"type": "FeatureCollection", "features": []}
    if wgs84:
        lon, lat = Transformer.from_crs(scene.crs, "EPSG:4326", always_xy=True).transform(ring[:, 0], ring[:, 1])
        ring = np.column_stack([lon, lat])
    else:
        doc["crs"] = {"type": "name", "properties": {"name": scene.crs}}
    coords = ring.tolist() + ring[:1].tolist()
    doc["features"].append({"type": "Feature", "properties": {"name": name, **properties},
                            "geometry": {"type": "Polygon", "coordinates": [coords]}})
    path.write_text(json.dumps(doc))
    return path


def _flown(route: Route, step: float = 0.05) -> np.ndarray:
    """Points every ``step`` m along the route's segments, ends included."""
    p = route.positions
    out = [p[:1]]
    for a, b in zip(p[:-1], p[1:]):
        n = max(int(np.ceil(np.linalg.norm(b - a) / step)), 1)
        out.append(a + (b - a) * (np.arange(1, n + 1) / n)[:, None])
    return np.vstack(out)


@pytest.fixture(scope="module")
def city(tmp_path_factory):
    folder = tmp_path_factory.mktemp("zones")
    scene = load_scene(CITY, building=HOUSE, context_radius=40)
    street = np.array([[STREET_X, -60.0], [STREET_X + 10, -60.0], [STREET_X + 10, 70.0], [STREET_X, 70.0]])
    c, r = np.array([3.0, 4.0]), 24.0
    property_ = np.array([[c[0] - r, c[1] - r], [c[0] + r, c[1] - r], [c[0] + r, c[1] + r], [c[0] - r, c[1] + r]])
    return folder, scene, street, property_


@pytest.fixture(scope="module")
def street_plan(city):
    """Planned through the CLI with the street kept out (zone file in WGS84), QGC exported."""
    folder, scene, street, _ = city
    zone = _polygon_file(folder / "street.geojson", scene, street, "street", wgs84=True)
    out = folder / "street.json"
    assert main(["plan", str(CITY), "--building", HOUSE, "--context-radius", "40", *PLAN, "--keep-out", str(zone),
                 "--export", "qgc,kml", "--quiet", "-o", str(out)]) == 0
    return out, Route.load(out), shapely.Polygon(street)


def test_the_street_is_never_entered(street_plan):
    _out, route, street = street_plan
    p = route.positions
    lines = shapely.linestrings(np.stack([p[:-1, :2], p[1:, :2]], axis=1))
    assert not shapely.intersects(street, lines).any()  # exact, on every segment
    flown = _flown(route)
    assert not shapely.contains_xy(street, flown[:, 0], flown[:, 1]).any()
    # and with the margin against the drone's own position error (1.5 m for a GNSS drone)
    assert route.params["zone_margin_m"] == pytest.approx(1.5)
    assert shapely.distance(street, lines).min() >= 1.5 - 1e-6


def test_the_surface_only_the_street_sees_is_reported_and_the_rest_covered(street_plan, city):
    _out, route, _street = street_plan
    scene = city[1]
    ev = evaluate(route, scene)
    assert ev.safe and ev.metrics["zone_breach_count"] == 0
    given_up = [g for g in ev.metrics["unreachable"] if g["reason"] == "reachable only from keep-out zone street"]
    assert given_up and given_up[0]["area_m2"] > 20.0  # the east wall, facing the street
    assert given_up[0]["centroid"][0] == pytest.approx(6.0, abs=0.5)
    assert ev.coverage_pct >= 99.5  # on fresh samples, of what the street leaves reachable
    assert any("keep-out zone street" in u["reason"] for u in route.uncovered)


def test_the_geofence_reaches_the_autopilot(street_plan, city):
    """MAVSDK's own importer reads the .plan's geofence; the mission and the fence are uploaded
    over MAVLink to a MAVSDK autopilot on 127.0.0.1, and every mission item arrives."""
    out, route, street = street_plan
    data, mission, arrived = mavsdk_upload(out.with_suffix(".plan"))
    fence = data.geofence_items
    assert [f.command for f in fence] == [FENCE_EXCLUSION] * 4
    assert all(int(f.param1) == 4 for f in fence)  # one polygon of four vertices
    lat = np.array([f.x for f in fence]) / 1e7
    lon = np.array([f.y for f in fence]) / 1e7
    x, y = Transformer.from_crs("EPSG:4326", city[1].crs, always_xy=True).transform(lon, lat)
    local = city[1].to_local(np.column_stack([x, y, np.zeros(len(x))]))[:, :2]
    assert shapely.Polygon(local).symmetric_difference(street).area < 0.01 * street.area
    assert arrived == len(data.mission_items)
    mission.upload_geofence(fence)
    assert len(data.mission_items) >= 2 * int(route.shot.sum())  # a waypoint and a photo per shot at least


def test_kml_draws_the_zone(street_plan):
    from lxml import etree
    out, _route, _street = street_plan
    tree = etree.parse(str(out.with_suffix(".kml")))
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    names = tree.xpath("//k:Placemark/k:name/text()", namespaces=ns)
    assert "keep-out zone street" in names


def test_keep_in_the_property(city, tmp_path):
    folder, scene, _, property_ = city
    zones = read_zones(keep_in=[_polygon_file(tmp_path / "property.geojson", scene, property_, "property")],
                       scene=scene)
    route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0, zones=zones)
    fence = shapely.Polygon(property_)
    p = route.positions
    lines = shapely.linestrings(np.stack([p[:-1, :2], p[1:, :2]], axis=1))
    assert shapely.covers(fence, lines).all()
    assert shapely.distance(fence.boundary, lines).min() >= 1.5 - 1e-6
    ev = evaluate(route, scene)
    assert ev.safe and ev.coverage_pct >= 99.5
    assert ev.metrics["unreachable_area_m2"] < 0.01 * ev.metrics["surface_area_m2"]
    from coverplan.io.qgc import fence_polygons
    assert [f["inclusion"] for f in fence_polygons(route)] == [True]


def test_evaluate_judges_a_route_against_zones_it_was_not_planned_with(street_plan, city, tmp_path, capsys):
    """A plan without zones, judged against the street: its segments over it are listed and
    it is unsafe; --strict fails it."""
    folder, scene, street, _ = city
    route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0)
    out = tmp_path / "free.json"
    route.save(out)
    zone = _polygon_file(tmp_path / "street.geojson", scene, street, "street")
    code = main(["evaluate", str(out), "--target", str(CITY), "--building", HOUSE, "--context-radius", "40",
                 "--keep-out", str(zone), "--json", "--strict"])
    m = json.loads(capsys.readouterr().out)
    p = route.positions
    lines = shapely.linestrings(np.stack([p[:-1, :2], p[1:, :2]], axis=1))
    crossing = set(np.flatnonzero(shapely.intersects(shapely.Polygon(street), lines)).tolist())
    assert crossing  # the free plan does fly over the street
    listed = {b["segment"] for b in m["zone_breaches"] if "segment" in b}
    assert listed == crossing or (m["zone_breach_count"] > 50 and listed <= crossing)
    assert not m["safe"] and code == 1


def test_a_zone_with_a_ceiling_is_flown_over(tmp_path):
    """Airspace below 12 m over the east half kept out: the flight may still pass above it."""
    from coverplan.world.scene import scene_from_meshes
    from tests.helpers import box
    scene = scene_from_meshes([box(0, 0, 0, 10, 10, 10)])
    low = Zone("yard", "keep-out", shapely.box(12, -40, 60, 50), -np.inf, 12.0)
    route = plan(scene, get_camera("phantom4pro"), gsd=0.005, security=3.0, zones=Zones((low,)))
    flown = _flown(route)
    over = shapely.contains_xy(low.polygon.buffer(1.5), flown[:, 0], flown[:, 1])
    assert (flown[over, 2] >= 12.0 + 1.5 - 1e-6).all()
    assert evaluate(route, scene).coverage_pct >= 99.5


# Property: the exact segment test never lets through a segment that enters a prism (checked
# every 1 mm) and never refuses one that stays 1 mm clear of it.
coords = st.floats(-20, 20, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(coords, coords), min_size=3, max_size=8), st.floats(-5, 5), st.floats(0.5, 10),
       st.lists(st.tuples(coords, coords, st.floats(-10, 20)), min_size=2, max_size=2),
       st.sampled_from(["keep-out", "keep-in"]))
def test_segment_test_agrees_with_dense_sampling(seed_only_draws, points, floor, height, ends, kind):
    hull = shapely.MultiPoint(points).convex_hull
    if hull.geom_type != "Polygon" or hull.area < 1.0:
        return
    zone = Zones((Zone("z", kind, hull, floor, floor + height),))
    a, b = (np.array(e, dtype=float) for e in ends)
    length = float(np.linalg.norm(b - a))
    t = np.linspace(0.0, 1.0, max(int(length / 1e-3), 2))
    pts = a + t[:, None] * (b - a)
    inside = shapely.covers(hull, shapely.points(pts[:, :2])) & (pts[:, 2] >= floor) & (pts[:, 2] <= floor + height)
    grown = hull.buffer(1e-3)
    near = shapely.covers(grown, shapely.points(pts[:, :2])) & (pts[:, 2] >= floor - 1e-3) & \
        (pts[:, 2] <= floor + height + 1e-3)
    allowed = bool(zone.segments_allowed(a[None], b[None])[0])
    if kind == "keep-out":
        assert not (allowed and inside.any())
        assert allowed or near.any()
    else:
        shrunk = hull.buffer(-1e-3)
        deep = shapely.covers(shrunk, shapely.points(pts[:, :2])) & (pts[:, 2] >= floor + 1e-3) & \
            (pts[:, 2] <= floor + height - 1e-3)
        assert not (allowed and not inside.all())
        assert allowed or not deep.all()


def test_the_report_draws_the_zones(street_plan, city, tmp_path):
    """The HTML report carries the street as a keep-out prism with a layer switch, and the
    overview figure draws it."""
    import base64

    from coverplan.report.figures import overview
    from coverplan.report.html import render_html, report_data
    _out, route, street = street_plan
    scene = city[1]
    ev = evaluate(route, scene)
    zones = [m for m in report_data(route, scene, ev)["meshes"] if m["role"] == "keep-out"]
    assert [m["name"] for m in zones] == ["keep-out zone street"]
    v = np.frombuffer(base64.b64decode(zones[0]["positions"]), np.float32).reshape(-1, 3)
    assert shapely.Polygon(street).buffer(1e-3).covers(shapely.MultiPoint(v[:, :2]))  # the prism stands on the street
    assert "data-layer=zones" in render_html(route, scene, ev)
    assert overview(route, scene, tmp_path / "overview.png").stat().st_size > 10_000
