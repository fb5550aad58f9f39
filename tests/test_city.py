"""CityGML / CityJSON input: the shipped citygml4j samples and hand-made edge cases."""

from __future__ import annotations

import gzip
import json

import numpy as np
import pytest

from coverplan import InputFileError, ParameterError, evaluate, get_camera, load_scene, plan
from coverplan.cli import main
from coverplan.io.city import parse_crs, triangulate_rings
from coverplan.shots.check_samples import planner_check_samples
from tests.helpers import MESHES

CITY = MESHES / "citygml"
HOUSE = "FZK_GUID_1F3E679D-E226-4535-926C-7390977FB25A"  # 6 x 8 m, 11 m ridge, corner at (0, 0)


@pytest.mark.parametrize("name", ["lod2_buildings_v3.gml.gz", "lod2_buildings_v2.json.gz"])
def test_lod2_house_reads_the_same_from_citygml_and_cityjson(name):
    scene = load_scene(CITY / name, building=HOUSE, context_radius=20)
    target = scene.targets[0].mesh
    assert target.is_watertight
    np.testing.assert_allclose(target.bounds, [[0, 0, 0], [6, 8, 11]], atol=1e-6)
    # 2 walls 8 x 5, 2 gable walls 6 x 5 + triangle, 2 roof planes of 8 x sqrt(3^2 + 6^2), floor 6 x 8
    expected = 2 * 8 * 5 + 2 * (6 * 5 + 0.5 * 6 * 6) + 2 * 8 * np.hypot(3, 6) + 6 * 8
    assert target.area == pytest.approx(expected, rel=1e-6)
    assert target.volume > 0
    assert scene.crs == "EPSG:3068"
    assert 0 < len(scene.obstacles) < 99
    assert all(p.role == "obstacle" for p in scene.parts[1:])


def test_lod3_building_with_openings_plans_and_is_covered():
    scene = load_scene(CITY / "lod3_building_v2.gml.gz")
    assert scene.vertical_crs == "EPSG:5783" and len(scene.targets) == 1
    assert any("not a closed solid" in n for n in scene.notes)
    assert any("skipped 1 polygons" in n for n in scene.notes)
    route = plan(scene, get_camera("phantom4pro"), gsd=0.005, security=5.0)
    ev = evaluate(route, scene)
    assert ev.safe and ev.metrics["coverage_pct"] >= 99.9
    # What is missed is listed with its reason (a window reveal only two safe viewpoints see).
    listed = {tuple(np.round(u["position"], 6)) for u in route.uncovered}
    mine = evaluate(route, scene, samples=planner_check_samples(scene, route))  # the samples route.uncovered lists
    missed = np.flatnonzero(mine.reachable & ~mine.covered)
    assert all(tuple(np.round(mine.samples.points[k], 6)) in listed for k in missed)
    assert ev.metrics["reachable_area_m2"] > 0.95 * ev.metrics["surface_area_m2"]


def test_neighbours_are_avoided_as_obstacles():
    scene = load_scene(CITY / "lod2_buildings_v3.gml.gz", building=HOUSE, context_radius=40)
    route = plan(scene, get_camera("phantom4pro"), gsd=0.005, security=5.0)
    ev = evaluate(route, scene)
    assert ev.safe and ev.metrics["min_clearance_m"] >= 5.0
    d, which = scene.clearance_model(5.0).segment_distance(route.positions[:-1], route.positions[1:])
    assert d.min() >= 5.0
    assert any(scene.parts[w].role == "obstacle" for w in which[d < d.min() + 3.0])  # they constrain the route


def test_crs_strings():
    assert parse_crs("urn:ogc:def:crs,crs:EPSG:6.12:3068,crs:EPSG:6.12:5783") == ("EPSG:3068", "EPSG:5783")
    assert parse_crs("urn:ogc:def:crs:EPSG::25832") == ("EPSG:25832", None)
    assert parse_crs("https://www.opengis.net/def/crs/EPSG/0/7415") == ("EPSG:7415", None)
    assert parse_crs("EPSG:28992") == ("EPSG:28992", None)
    assert parse_crs(None) == (None, None)


def test_polygon_with_a_hole_and_repeated_closing_point():
    outer = np.array([[0, 0, 0], [10, 0, 0], [10, 0, 10], [0, 0, 10], [0, 0, 0]], float)
    hole = np.array([[4, 0, 4], [4, 0, 6], [6, 0, 6], [6, 0, 4], [4, 0, 4]], float)
    tri = triangulate_rings([outer, hole])
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    assert area.sum() == pytest.approx(100 - 4)
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert (normals[:, 1] < 0).all()  # the ring runs so its normal points to -y; triangles keep it
    assert triangulate_rings([outer[:2]]) is None
    assert triangulate_rings([np.array([[0, 0, 0], [1, 1, 1], [2, 2, 2]], float)]) is None


def cityjson(tmp_path, objects, vertices, name="t.city.json", crs="https://www.opengis.net/def/crs/EPSG/0/25832"):
    doc = {"type": "CityJSON", "version": "2.0", "transform": {"scale": [0.01, 0.01, 0.01], "translate": [500000, 5400000, 100]},
           "metadata": {"referenceSystem": crs}, "CityObjects": objects, "vertices": vertices}
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


def box_solid(x0, y0, x1, y1, h, lod="2"):
    v = [[x0, y0, 0], [x1, y0, 0], [x1, y1, 0], [x0, y1, 0], [x0, y0, h], [x1, y0, h], [x1, y1, h], [x0, y1, h]]
    faces = [[[0, 3, 2, 1]], [[4, 5, 6, 7]], [[0, 1, 5, 4]], [[1, 2, 6, 5]], [[2, 3, 7, 6]], [[3, 0, 4, 7]]]
    return v, {"type": "Solid", "lod": lod, "boundaries": [faces]}


def test_cityjson_parts_transform_and_far_coordinates(tmp_path):
    v1, g1 = box_solid(0, 0, 1000, 800, 1200)  # in cm: 10 x 8 x 12 m
    v2, g2 = box_solid(2000, 0, 2300, 300, 900)
    g2 = {**g2, "boundaries": [[[[i + 8 for i in ring] for ring in face] for face in g2["boundaries"][0]]]}
    objects = {"B1": {"type": "Building", "children": ["B1-p"]}, "B1-p": {"type": "BuildingPart", "parents": ["B1"], "geometry": [g1]},
               "T": {"type": "SolitaryVegetationObject", "geometry": [g2]}}
    path = cityjson(tmp_path, objects, v1 + v2)
    scene = load_scene(path, building="B1")
    assert scene.crs == "EPSG:25832"
    assert scene.origin[0] == pytest.approx(500005, abs=1) and scene.origin[1] == pytest.approx(5400004, abs=1)
    np.testing.assert_allclose(scene.targets[0].mesh.extents, [10, 8, 12], atol=1e-6)
    assert [p.role for p in scene.parts] == ["target", "obstacle"]
    np.testing.assert_allclose(scene.to_source(scene.targets[0].mesh.bounds)[0], [500000, 5400000, 100], atol=1e-6)


def test_cityjson_seq_and_gzip(tmp_path):
    v, g = box_solid(0, 0, 1000, 800, 1200)
    lines = [{"type": "CityJSON", "version": "2.0", "transform": {"scale": [0.01] * 3, "translate": [0, 0, 0]},
              "CityObjects": {}, "vertices": [], "metadata": {"referenceSystem": "EPSG:7415"}},
             {"type": "CityJSONFeature", "id": "B", "CityObjects": {"B": {"type": "Building", "geometry": [g]}}, "vertices": v}]
    path = tmp_path / "t.city.jsonl.gz"
    with gzip.open(path, "wt") as fh:
        fh.write("\n".join(json.dumps(x) for x in lines))
    scene = load_scene(path)
    assert scene.crs == "EPSG:7415" and scene.targets[0].mesh.is_watertight


def test_degenerate_polygon_is_skipped_and_counted(tmp_path):
    v, g = box_solid(0, 0, 1000, 800, 1200)
    v += [[0, 0, 0], [0, 0, 0], [0, 0, 0]]
    g["boundaries"][0].append([[8, 9, 10]])  # three identical points
    scene = load_scene(cityjson(tmp_path, {"B": {"type": "Building", "geometry": [g]}}, v))
    assert any("skipped 1 polygons" in n for n in scene.notes)
    assert scene.targets[0].mesh.is_watertight


def test_unsupported_lod(tmp_path):
    v, g = box_solid(0, 0, 1000, 800, 1200, lod="1")
    path = cityjson(tmp_path, {"B": {"type": "Building", "geometry": [g]}}, v)
    with pytest.raises(InputFileError, match="no LoD 3"):
        load_scene(path, lod=3)
    with pytest.raises(InputFileError, match="footprints"):
        load_scene(path, lod=0)
    assert load_scene(path, lod=1).targets[0].mesh.is_watertight


def run(capsys, *args):
    try:
        code = main([str(a) for a in args])
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    return code, err


@pytest.mark.parametrize("args, words", [
    (["--building", "NOPE"], ["no city object with id", "FZK_GUID_"]),
    ([], ["100 buildings", "--building"]),
    (["--building", HOUSE, "--lod", "4"], ["no lod 4"]),
])
def test_city_input_errors_are_one_line(capsys, tmp_path, args, words):
    code, err = run(capsys, "plan", CITY / "lod2_buildings_v3.gml.gz", *args, "--camera", "phantom4pro",
                    "--gsd", "0.005", "--security", "5", "-o", tmp_path / "r.json")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    for w in words:
        assert w.lower() in err.lower()


@pytest.mark.parametrize("name, content, words", [
    ("broken.gml", "<CityModel><cityObjectMember><Building>", ["broken.gml", "not well-formed xml"]),
    ("other.gml", "<?xml version='1.0'?><html></html>", ["not citygml"]),
    ("broken.city.json", '{"type": "CityJSON", "CityObjects": {', ["broken.city.json", "not valid json"]),
    ("notcity.json", '{"type": "FeatureCollection"}', ["not cityjson"]),
])
def test_broken_city_files(capsys, tmp_path, name, content, words):
    path = tmp_path / name
    path.write_text(content)
    code, err = run(capsys, "plan", path, "--camera", "phantom4pro", "--gsd", "0.005", "--security", "5",
                    "-o", tmp_path / "r.json")
    assert code == 2 and len(err.strip().splitlines()) == 1
    for w in words:
        assert w.lower() in err.lower()


def test_geographic_export_without_crs_is_refused_before_planning(capsys, tmp_path):
    code, err = run(capsys, "plan", MESHES / "gabled_house.obj", "--camera", "phantom4pro", "--gsd", "0.005",
                    "--security", "3", "-o", tmp_path / "r.json", "--export", "kml")
    assert code == 2 and "georeference" in err and "--crs" in err
    assert not (tmp_path / "r.json").exists()


def test_contradictory_crs(tmp_path):
    with pytest.raises(ParameterError, match="contradicts"):
        load_scene(CITY / "lod2_buildings_v2.json.gz", building=HOUSE, crs="EPSG:25832")
