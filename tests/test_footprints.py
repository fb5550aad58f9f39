"""Footprints with heights (GeoJSON in longitude/latitude, GeoPackage in a projected CRS) as
closed buildings, checked against areas and volumes computed independently."""

from __future__ import annotations

import json

import numpy as np
import pytest
import shapely
from pyproj import Geod, Transformer
from shapely.geometry import Polygon, box, mapping

from coverplan import evaluate, get_camera, load_scene, plan
from coverplan.cli import main
from coverplan.errors import InputFileError, ParameterError

LON0, LAT0 = 9.1829, 48.7758  # Stuttgart
M_PER_DEG_LAT = 111_200.0


def to_lonlat(poly: Polygon) -> Polygon:
    """A polygon drawn in metres east/north of (LON0, LAT0), in degrees (close enough for a test site)."""
    k = M_PER_DEG_LAT * np.cos(np.radians(LAT0))
    return shapely.transform(poly, lambda xy: np.column_stack([LON0 + xy[:, 0] / k, LAT0 + xy[:, 1] / M_PER_DEG_LAT]))


FOOTPRINTS = {  # id: (footprint in metres, eaves height, ridge above the eaves)
    "house": (box(0, 0, 12, 8), 6.0, 3.0),
    "ell": (Polygon([(20, 0), (32, 0), (32, 10), (26, 10), (26, 5), (20, 5)]), 9.0, 0.0),
    "court": (box(0, 20, 20, 40).difference(box(6, 26, 14, 34)), 7.5, 0.0),
}


@pytest.fixture
def geojson(tmp_path):
    features = [{"type": "Feature", "id": fid, "properties": {"h": h, "ridge": r, "name": fid},
                 "geometry": mapping(to_lonlat(poly))} for fid, (poly, h, r) in FOOTPRINTS.items()]
    path = tmp_path / "footprints.geojson"
    path.write_text(json.dumps({"type": "FeatureCollection", "features": features}))
    return path


def test_footprints_become_closed_buildings_of_the_right_size(geojson):
    scene = load_scene(geojson, building="house", height_attribute="h", roof_attribute="ridge")
    assert scene.crs == "EPSG:32632"  # Stuttgart's UTM zone
    [target] = scene.targets
    assert target.mesh.is_watertight
    geod_area = abs(Geod(ellps="WGS84").geometry_area_perimeter(to_lonlat(FOOTPRINTS["house"][0]))[0])
    # a gable over 12 x 8 m: box 6 m plus a prism 3 m high along the long side
    assert target.mesh.volume == pytest.approx(geod_area * 6.0 + geod_area * 3.0 / 2.0, rel=0.003)
    assert np.ptp(target.mesh.vertices[:, 2]) == pytest.approx(9.0, abs=1e-3)
    names = sorted(p.name for p in scene.obstacles)
    assert len(names) == 2
    court = next(p for p in scene.obstacles if "court" in p.name)
    area = 20 * 20 - 8 * 8
    assert court.mesh.volume == pytest.approx(area * 7.5, rel=0.005) and court.mesh.is_watertight


def test_a_footprint_building_is_planned_and_exported(geojson, tmp_path, capsys):
    scene = load_scene(geojson, building="ell", height_attribute="h")
    route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0)
    ev = evaluate(route, scene)
    assert ev.safe and ev.coverage_pct >= 99.0
    assert main(["plan", str(geojson), "--building", "ell", "--height-attribute", "h", "--camera", "phantom4pro",
                 "--gsd", "0.004", "--security", "3", "-o", str(tmp_path / "ell.json"), "--export", "kml", "-q",
                 "--no-evaluate"]) == 0
    kml = (tmp_path / "ell.kml").read_text()
    first = [float(v) for v in kml.split("<coordinates>")[1].split()[0].split(",")[:2]]
    assert abs(first[0] - LON0) < 0.002 and abs(first[1] - LAT0) < 0.002  # within ~150 m of the site


def test_geopackage_in_a_projected_crs(tmp_path):
    pyogrio = pytest.importorskip("pyogrio")
    to_utm = Transformer.from_crs("EPSG:4326", "EPSG:25832", always_xy=True)
    polys = [shapely.transform(to_lonlat(p), lambda xy: np.column_stack(to_utm.transform(xy[:, 0], xy[:, 1])))
             for p, _h, _r in FOOTPRINTS.values()]
    path = tmp_path / "footprints.gpkg"
    pyogrio.raw.write(path, geometry=shapely.to_wkb(np.array(polys, dtype=object)), field_data=[
        np.array(list(FOOTPRINTS)), np.array([h for _p, h, _r in FOOTPRINTS.values()])],
        fields=["id", "height"], crs="EPSG:25832", geometry_type="Polygon", driver="GPKG")
    scene = load_scene(path, building="court", height_attribute="height")
    assert scene.crs == "EPSG:25832" and len(scene.obstacles) == 2
    assert scene.targets[0].mesh.volume == pytest.approx(polys[2].area * 7.5, rel=1e-6)


def test_footprint_mistakes_are_named(geojson, tmp_path):
    with pytest.raises(ParameterError, match="--height-attribute NAME or --height M"):
        load_scene(geojson, building="house")
    with pytest.raises(InputFileError, match="footprint house has no 'floors'"):
        load_scene(geojson, building="house", height_attribute="floors")
    flat = load_scene(geojson, building="house", height_attribute="floors", height=4.0)
    assert np.ptp(flat.targets[0].mesh.vertices[:, 2]) == pytest.approx(4.0)
    bad = tmp_path / "bad.geojson"
    bad.write_text(json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"h": "tall"}, "geometry": mapping(to_lonlat(box(0, 0, 5, 5)))}]}))
    with pytest.raises(InputFileError, match="h is 'tall', not a number"):
        load_scene(bad, height_attribute="h")


def test_bundled_footprints_plan_as_the_readme_says(tmp_path, capsys):
    """The README's command on meshes/footprints.geojson: the gabled house is planned safe
    around its three neighbours."""
    from coverplan.flight.route import Route
    from tests.helpers import MESHES
    out = tmp_path / "house.json"
    assert main(["plan", str(MESHES / "footprints.geojson"), "--building", "house", "--height-attribute", "height",
                 "--roof-attribute", "ridge", "--camera", "phantom4pro", "--gsd", "0.004", "--security", "3",
                 "-o", str(out), "--export", "kml", "--quiet"]) == 0
    route = Route.load(out)
    assert route.metrics["evaluation"]["safe"] and route.metrics["evaluation"]["coverage_pct"] >= 99.5
    assert (tmp_path / "house.kml").exists()
    scene = load_scene(MESHES / "footprints.geojson", building="house", height_attribute="height",
                       roof_attribute="ridge")
    assert len(scene.obstacles) == 3 and scene.bounds("target")[1, 2] == pytest.approx(9.0, abs=0.01)  # eaves 6 + ridge 3
