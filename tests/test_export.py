"""Exports parsed back by independent readers: positions to 0.1 m, headings to 0.5 degrees.

Coordinates go back through pyproj directly (not coverplan.geometry.geo), true headings are checked
against geodesic azimuths of each waypoint's local heading, and the file structure against
what QGroundControl, Litchi and Google Earth read.
"""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from lxml import etree
from pyproj import Geod, Transformer

from coverplan import Route, get_camera, load_scene, plan
from coverplan.cli import main
from coverplan.io import export_route, writer
from tests.helpers import MESHES

HOUSE = "FZK_GUID_1F3E679D-E226-4535-926C-7390977FB25A"
GEOD = Geod(ellps="WGS84")
MAV_COMMANDS = {16, 20, 22, 178, 1000, 2000}  # 178: DO_CHANGE_SPEED, where a route flown through slows


@pytest.fixture(scope="module")
def route():
    scene = load_scene(MESHES / "citygml" / "lod2_buildings_v3.gml.gz", building=HOUSE, context_radius=30)
    return plan(scene, get_camera("phantom4pro"), gsd=0.003, security=4.0)


def to_local(route, lon, lat):
    x, y = Transformer.from_crs("EPSG:4326", route.frame["crs"], always_xy=True).transform(lon, lat)
    return np.column_stack([x, y]) - np.asarray(route.frame["origin"][:2])


def true_heading(route, k):
    """Azimuth on the ellipsoid of a 1 m step along waypoint k's local heading."""
    h = np.radians(route.heading_deg[k])
    p = route.positions[k, :2] + route.frame["origin"][:2]
    q = p + [np.sin(h), np.cos(h)]
    t = Transformer.from_crs(route.frame["crs"], "EPSG:4326", always_xy=True)
    (lon1, lon2), (lat1, lat2) = t.transform([p[0], q[0]], [p[1], q[1]])
    return GEOD.inv(lon1, lat1, lon2, lat2)[0] % 360


def angle_diff(a, b):
    return np.abs((np.asarray(a) - np.asarray(b) + 180) % 360 - 180)


def export(route, name, tmp_path, **options):
    func, suffix = writer(name)
    return func(route, tmp_path / f"flight{suffix}", **options)


def test_qgc_plan(route, tmp_path):
    (path,) = export(route, "qgc", tmp_path)
    plan_file = json.loads(path.read_text())
    assert plan_file["fileType"] == "Plan" and plan_file["version"] == 1
    assert isinstance(plan_file["groundStation"], str)
    assert plan_file["geoFence"]["version"] == 2 and plan_file["rallyPoints"]["version"] == 2
    mission = plan_file["mission"]
    assert mission["version"] == 2 and mission["firmwareType"] in (3, 12) and isinstance(mission["vehicleType"], int)
    home = mission["plannedHomePosition"]
    assert len(home) == 3 and all(isinstance(v, (int, float)) for v in home)
    items = mission["items"]
    for n, item in enumerate(items, start=1):
        assert item["type"] == "SimpleItem" and item["autoContinue"] is True and item["doJumpId"] == n
        assert item["command"] in MAV_COMMANDS and item["frame"] in (2, 3)
        assert len(item["params"]) == 7 and all(p is None or isinstance(p, (int, float)) for p in item["params"])
    assert items[0]["command"] == 22 and items[-1]["command"] == 20
    nav = [i for i in items if i["command"] == 16]
    assert len(nav) == len(route) - 1
    lat = np.array([i["params"][4] for i in nav])
    lon = np.array([i["params"][5] for i in nav])
    xy = to_local(route, lon, lat)
    np.testing.assert_allclose(xy, route.positions[1:, :2], atol=0.1)
    ground = route.params["ground_z_m"]
    np.testing.assert_allclose([i["params"][6] for i in nav], route.positions[1:, 2] - ground, atol=0.1)
    expect = [true_heading(route, k) for k in range(1, len(route))]
    assert angle_diff([i["params"][3] for i in nav], expect).max() < 0.5
    photos = sum(1 for i in items if i["command"] == 2000)
    assert photos == route.shot.sum()
    # The gimbal holds the pitch last set (set before the first photo, then where it changes).
    held, at_photo = None, []
    for i in items:
        if i["command"] == 1000:
            assert i["params"][0] != held
            held = i["params"][0]
        elif i["command"] == 2000:
            at_photo.append(held)
    assert None not in at_photo
    np.testing.assert_allclose(at_photo, route.pitch_deg[route.shot], atol=0.01)


def test_a_plan_longer_than_px4_keeps_is_refused_and_ardupilot_gets_it(tmp_path):
    from coverplan.errors import ParameterError
    from coverplan.io.qgc import PX4_MISSION_ITEMS, mission_items
    n = 400
    wps = [{"position": [2.0 * k, 0, 10], "shot": k % 2 == 1, "heading_deg": 0, "gimbal_pitch_deg": -10.0 * (k % 4 == 1),
            "leg": "coverage"} for k in range(n)]
    route = Route.from_dict({"format": "coverplan-route", "version": 1, "units": "m",
                             "frame": {"crs": "EPSG:25832", "origin": [500000, 5400000, 0]},
                             "camera": {"sensor_width_mm": 13.2, "sensor_height_mm": 8.8, "focal_length_mm": 8.8,
                                        "image_width_px": 5472, "image_height_px": 3648},
                             "params": {"gsd_m": 0.004, "security_m": 3.0}, "waypoints": wps})
    items = len(mission_items(route))
    assert items > PX4_MISSION_ITEMS
    with pytest.raises(ParameterError, match=f"the flight has {items} mission items, but PX4 keeps at most 500"):
        export_route(route, tmp_path / "long", ["qgc"])
    assert not list(tmp_path.iterdir())
    (path,) = export_route(route, tmp_path / "long", ["qgc"], firmware="ardupilot")
    assert len(json.loads(path.read_text())["mission"]["items"]) == items


def test_wpl(route, tmp_path):
    (path,) = export(route, "wpl", tmp_path)
    lines = path.read_text().splitlines()
    assert lines[0] == "QGC WPL 110"
    rows = [line.split("\t") for line in lines[1:]]
    assert all(len(r) == 12 for r in rows)
    assert [int(r[0]) for r in rows] == list(range(len(rows)))
    nav = [r for r in rows[1:] if int(r[3]) == 16]
    xy = to_local(route, [float(r[9]) for r in nav], [float(r[8]) for r in nav])
    np.testing.assert_allclose(xy, route.positions[1:, :2], atol=0.1)
    assert all(np.isfinite(float(v)) for r in rows for v in r)


def test_litchi(route, tmp_path):
    paths = export(route, "litchi", tmp_path)
    rows = []
    for p in paths:
        with open(p, newline="") as fh:
            reader = csv.DictReader(fh)
            assert reader.fieldnames[:8] == ["latitude", "longitude", "altitude(m)", "heading(deg)", "curvesize(m)",
                                             "rotationdir", "gimbalmode", "gimbalpitchangle"]
            assert "actiontype15" in reader.fieldnames and reader.fieldnames[-1] == "photo_distinterval"
            chunk = list(reader)
            assert len(chunk) <= 99
            rows += chunk if not rows else chunk[1:]  # each later mission starts where the last ended
    xy = to_local(route, [float(r["longitude"]) for r in rows], [float(r["latitude"]) for r in rows])
    # every waypoint is within 0.1 m of a route waypoint, and every route waypoint where the path
    # turns or a photo is taken has one within 0.6 m; Litchi stops at each, so the turn points
    # between photos, where the path runs straight on, are left out
    corner = ~route.straight_points()
    assert (~corner).any()
    d = np.linalg.norm(xy[:, None, :] - route.positions[None, :, :2], axis=2)
    assert d.min(axis=1).max() < 0.1 and d[:, corner].min(axis=0).max() < 0.6
    assert len(rows) <= corner.sum()
    photos = sum(1 for r in rows for k in range(1, 16) if r[f"actiontype{k}"] == "1")
    assert photos == route.shot.sum()
    for r in rows:
        assert 0 <= float(r["heading(deg)"]) < 360 and -90 <= float(r["gimbalpitchangle"]) <= 30


def test_kml(route, tmp_path):
    (path,) = export(route, "kml", tmp_path)
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    root = etree.parse(str(path)).getroot()
    assert root.tag == "{http://www.opengis.net/kml/2.2}kml"
    modes = {e.text for e in root.iterfind(".//k:altitudeMode", ns)}
    assert modes <= {"clampToGround", "relativeToGround", "absolute"}
    line = root.find(".//k:LineString/k:coordinates", ns).text.split()
    coords = np.array([[float(v) for v in c.split(",")] for c in line])
    assert len(coords) == len(route)
    np.testing.assert_allclose(to_local(route, coords[:, 0], coords[:, 1]), route.positions[:, :2], atol=0.1)
    # heights are above sea level here (the file names its height datum, EPSG:5783)
    np.testing.assert_allclose(coords[:, 2], route.positions[:, 2] + route.frame["origin"][2], atol=0.1)
    cams = root.findall(".//k:Camera", ns)
    assert len(cams) == route.shot.sum()
    shots = route.shots
    for cam, k in zip(cams, shots):
        heading = float(cam.find("k:heading", ns).text)
        tilt = float(cam.find("k:tilt", ns).text)
        assert 0 <= tilt <= 180 and abs(tilt - (90 + route.pitch_deg[k])) < 0.01
        assert angle_diff(heading, true_heading(route, k)) < 0.5


def test_kml_opens_at_the_right_place_on_earth(route, tmp_path):
    """The house's corner is at (0, 0) in EPSG:3068; the footprint in the KML must be there."""
    (path,) = export(route, "kml", tmp_path)
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    ring = etree.parse(str(path)).getroot().find(".//k:Polygon//k:coordinates", ns).text.split()
    corners = np.array([[float(v) for v in c.split(",")[:2]] for c in ring])
    lon, lat = Transformer.from_crs("EPSG:3068", "EPSG:4326", always_xy=True).transform(0.0, 0.0)
    dist = GEOD.inv(np.full(len(corners), lon), np.full(len(corners), lat), corners[:, 0], corners[:, 1])[2]
    assert dist.min() < 0.1
    assert 52.3 < lat < 52.4 and 13.0 < lon < 13.1  # near Potsdam: the Soldner Berlin grid


def test_geojson_and_csv(route, tmp_path):
    (gj,) = export(route, "geojson", tmp_path)
    doc = json.loads(gj.read_text())
    assert doc["type"] == "FeatureCollection"
    line = doc["features"][0]["geometry"]
    assert line["type"] == "LineString" and len(line["coordinates"]) == len(route)
    coords = np.array(line["coordinates"])
    assert (np.abs(coords[:, 0]) <= 180).all() and (np.abs(coords[:, 1]) <= 90).all()
    np.testing.assert_allclose(to_local(route, coords[:, 0], coords[:, 1]), route.positions[:, :2], atol=0.1)
    points = [f for f in doc["features"][1:] if f["properties"]["shot"]]
    assert len(points) == route.shot.sum()
    (path,) = export(route, "csv", tmp_path)
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    local = np.array([[float(r["x_m"]), float(r["y_m"]), float(r["z_m"])] for r in rows])
    np.testing.assert_allclose(local, route.positions, atol=1e-3)
    np.testing.assert_allclose([float(r["heading_deg"]) for r in rows], route.heading_deg, atol=1e-2)


def test_geodetic_origin_round_trip(tmp_path):
    """A plain mesh placed on Earth with --geo-origin: local ENU <-> WGS84."""
    scene = load_scene(MESHES / "gabled_house.obj", geodetic_origin=[47.3769, 8.5417, 408.0])
    route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0)
    (path,) = export(route, "geojson", tmp_path)
    coords = np.array(json.loads(path.read_text())["features"][0]["geometry"]["coordinates"])
    lat0, lon0 = 47.3769, 8.5417
    az, _back, dist = GEOD.inv(np.full(len(coords), lon0), np.full(len(coords), lat0), coords[:, 0], coords[:, 1])
    east, north = dist * np.sin(np.radians(az)), dist * np.cos(np.radians(az))
    np.testing.assert_allclose(np.column_stack([east, north]), route.positions[:, :2], atol=0.1)


def test_cli_export_and_plan_export(route, tmp_path, capsys):
    path = route.save(tmp_path / "flight.json")
    assert main(["export", str(path), "--format", "qgc,kml,litchi,geojson,wpl,csv"]) == 0
    for suffix in (".plan", ".kml", ".litchi.csv", ".geojson", ".waypoints", ".csv"):
        assert (tmp_path / f"flight{suffix}").exists()
    local = Route.load(path)
    local.frame = {"crs": None, "origin": [0, 0, 0]}
    bare = local.save(tmp_path / "bare.json")
    try:
        code = main(["export", str(bare), "--format", "kml"])
    except SystemExit as exc:
        code = exc.code
    assert code == 2 and "georeference" in capsys.readouterr().err
    code = main(["plan", str(MESHES / "citygml" / "lod2_buildings_v2.json.gz"), "--building", HOUSE,
                 "--camera", "phantom4pro", "--gsd", "0.005", "--security", "5", "-o", str(tmp_path / "j.json"),
                 "--export", "qgc,kml,litchi", "-q"])
    assert code == 0 and (tmp_path / "j.plan").exists() and (tmp_path / "j.kml").exists()
