"""Every row of the README's bad-input table, fed through the CLI: exit status 2, one line
naming the problem, no traceback (plus the non-error rows: they plan and say what happened)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from coverplan.cli import main
from tests.helpers import MESHES, box

L = str(MESHES / "l_prism.obj")
CITY = MESHES / "citygml"
HOUSE = "FZK_GUID_1F3E679D-E226-4535-926C-7390977FB25A"
PLAN = ["--camera", "phantom4pro", "--gsd", "0.004", "--security", "3"]


def run(capsys, *args) -> tuple[int, str, str]:
    try:
        code = main([str(a) for a in args])
    except SystemExit as exc:  # argparse
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


def assert_one_line_error(code, err, *words):
    assert code == 2, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    for w in words:
        assert w.lower() in lines[0].lower(), (w, lines[0])


def route_file(tmp_path, **change):
    d = {"format": "coverplan-route", "version": 1, "units": "m",
         "frame": {"crs": None, "origin": [0, 0, 0]},
         "camera": {"sensor_width_mm": 13.2, "sensor_height_mm": 8.8, "focal_length_mm": 8.8,
                    "image_width_px": 5472, "image_height_px": 3648},
         "params": {"gsd_m": 0.004, "security_m": 3.0},
         "waypoints": [{"position": [0, 0, 5], "shot": True, "heading_deg": 0, "gimbal_pitch_deg": 0,
                        "leg": "coverage"}]}
    d.update({k: v for k, v in change.items() if k != "raw"})
    path = tmp_path / "route.json"
    path.write_text(change.get("raw") or json.dumps(d))
    return path


def file_with(tmp_path, name, content):
    path = tmp_path / name
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    return path


def nan_obj(tmp_path):
    lines = box(0, 0, 0, 10, 10, 10).export(file_type="obj").splitlines()
    first = next(k for k, line in enumerate(lines) if line.startswith("v "))
    lines[first] = "v nan 0 0"
    return file_with(tmp_path, "nan.obj", "\n".join(lines))


# (row in the README table, CLI arguments built from tmp_path, words the message must hold)
ROWS = {
    "missing file": (lambda t: ["plan", t / "gone.obj", *PLAN, "-o", t / "r.json"], ["gone.obj", "no such file"]),
    "missing file, and options missing too": (lambda t: ["plan", t / "gone.plan", "-o", t / "r.json"],
                                              ["gone.plan", "no such file"]),
    "missing route to evaluate, no scene given": (lambda t: ["evaluate", t / "gone.json"], ["gone.json", "no such file"]),
    "empty file": (lambda t: ["plan", file_with(t, "empty.stl", b""), *PLAN, "-o", t / "r.json"], ["empty.stl", "empty"]),
    "unsupported format": (lambda t: ["plan", file_with(t, "m.xyz", "1 2 3"), *PLAN, "-o", t / "r.json"],
                           ["m.xyz", "unsupported format"]),
    "unreadable mesh (garbage STL)": (lambda t: ["plan", file_with(t, "j.stl", b"\x00\x01garbage" * 40), *PLAN,
                                                 "-o", t / "r.json"], ["j.stl"]),
    "unreadable mesh (not OBJ)": (lambda t: ["plan", file_with(t, "j.obj", "this is not an obj file\n"), *PLAN,
                                             "-o", t / "r.json"], ["j.obj"]),
    "mesh with no faces": (lambda t: ["plan", file_with(t, "p.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"), *PLAN,
                                      "-o", t / "r.json"], ["p.obj"]),
    "NaN/inf vertices": (lambda t: ["plan", nan_obj(t), *PLAN, "-o", t / "r.json"], ["nan"]),
    "target inside an obstacle": (lambda t: ["plan", MESHES / "gabled_house.obj", "--obstacles",
                                             _big_box(t), *PLAN, "-o", t / "r.json"], ["buried"]),
    "start inside a mesh": (lambda t: ["plan", L, *PLAN, "--start", "20", "20", "4", "-o", t / "r.json"],
                            ["inside", "l_prism"]),
    "start far from the target": (lambda t: ["plan", L, *PLAN, "--start", "512300", "5403830", "4", "-o", t / "r.json"],
                                  ["km from the target", "same coordinates as the input"]),
    "start within the security distance": (lambda t: ["plan", L, *PLAN, "--start", "13", "25", "4", "-o", t / "r.json"],
                                           ["closer than the security distance"]),
    "GSD finer than the security distance allows": (
        lambda t: ["plan", L, "--camera", "phantom4pro", "--gsd", "0.0005", "--security", "3", "-o", t / "r.json"],
        ["finest gsd"]),
    "unknown camera preset": (lambda t: ["plan", L, "--camera", "hasselblad", "--gsd", "0.004", "--security", "3",
                                         "-o", t / "r.json"], ["unknown camera preset", "phantom4pro"]),
    "camera with a zero or negative size": (
        lambda t: ["plan", L, "--sensor-mm", "0", "8.8", "--focal-mm", "8.8", "--image-px", "5472", "3648",
                   "--gsd", "0.004", "--security", "3", "-o", t / "r.json"], ["sensor_width_mm"]),
    "GSD <= 0": (lambda t: ["plan", L, "--camera", "phantom4pro", "--gsd", "-0.01", "--security", "3",
                            "-o", t / "r.json"], ["gsd"]),
    "spacing <= 0": (lambda t: ["plan", L, *PLAN, "--spacing", "0", "-o", t / "r.json"], ["spacing"]),
    "ceiling below the minimum altitude": (lambda t: ["plan", L, *PLAN, "--max-altitude", "2", "-o", t / "r.json"],
                                           ["--max-altitude", "not above the minimum altitude"]),
    "zone file that is not polygons": (lambda t: ["plan", L, *GEO, *PLAN, "--keep-out", _zone_file(
        t, {"type": "LineString", "coordinates": [[13.4, 52.5], [13.401, 52.5]]}), "-o", t / "r.json"],
        ["zone.geojson", "is a LineString, not a polygon"]),
    "zone file that is not GeoJSON": (lambda t: ["plan", L, *GEO, *PLAN, "--keep-out", file_with(t, "zone.geojson",
                                                 '{"type": "Topology"}'), "-o", t / "r.json"],
                                      ["zone.geojson", "not a GeoJSON FeatureCollection"]),
    "zones without a georeference": (lambda t: ["plan", L, *PLAN, "--keep-out", _zone_file(t, _square(13.4, 52.5)),
                                                "-o", t / "r.json"],
                                     ["zone.geojson is in WGS84", "--crs", "--geo-origin"]),
    "keep-in zone without the start": (lambda t: ["plan", L, *GEO, *PLAN, "--keep-in", _zone_file(t, _square(
        13.4, 52.5, 0.001)), "--start", "-90", "-150", "5", "-o", t / "r.json"],
        ["start point", "outside keep-in zone 0", "must start inside it"]),
    "keep-out zone over the whole target": (lambda t: ["plan", L, *GEO, *PLAN, "--keep-out", _zone_file(
        t, _square(13.4, 52.5, 0.002)), "-o", t / "r.json"],
        ["keep-out zone 0 covers the whole target", "nothing could be photographed"]),
    "check: a folder without photos": (lambda t: ["check", _folder(t), "--target", L, *GEO, "-o", t / "out"],
                                       ["photos", "holds no photos"]),
    "check: photos without a georeferenced scene": (lambda t: ["check", _folder(t, photos=1), "--target", L,
                                                               "-o", t / "out"],
                                                    ["the scene has no georeference", "--geo-origin"]),
    "check: photos without GPS": (lambda t: ["check", _folder(t, photos=3, gps=False), "--target", L, *GEO,
                                             "-o", t / "out"],
                                  ["photos", "0 photo(s) with a GPS position", "at least 2"]),
    "check: a camera the EXIF does not name": (lambda t: ["check", _folder(t, photos=3, focal=False), "--target", L,
                                                          *GEO, "-o", t / "out"],
                                               ["photos", "give no focal length", "FocalLengthIn35mmFilm"]),
    "mission with a complex item not expanded": (lambda t: ["evaluate", _plan_with_complex(t, "FWLanding"), "--target",
                                                            L, *GEO, "--camera", "phantom4pro", "--gsd", "0.004",
                                                            "--security", "3"],
                                                 ["mission item 2 is a FWLanding item", "does not expand"]),
    "existing photos that do not exist": (lambda t: ["plan", L, *PLAN, "--existing", t / "flown", "-o", t / "r.json"],
                                          ["flown", "no such file or folder"]),
    "zone floor above its ceiling": (lambda t: ["plan", L, *GEO, *PLAN, "--keep-out", _zone_file(
        t, _square(13.41, 52.5), floor=30, ceiling=10), "-o", t / "r.json"],
        ["zone 0: floor 30 m is not below its ceiling 10 m"]),
    "contradictory units": (lambda t: ["plan", CITY / "lod2_buildings_v2.json.gz", "--building", HOUSE, "--units", "mm",
                                       *PLAN, "-o", t / "r.json"], ["--units mm", "contradicts", "EPSG:3068"]),
    "contradictory CRS": (lambda t: ["plan", CITY / "lod2_buildings_v2.json.gz", "--building", HOUSE, "--crs",
                                     "EPSG:25832", *PLAN, "-o", t / "r.json"], ["contradicts"]),
    "scene larger than memory allows": (lambda t: ["plan", L, *PLAN, "--spacing", "0.01", "--max-memory-gb", "1",
                                                   "-o", t / "r.json"], ["needs about", "gb", "--spacing"]),
    "route file that is not a route": (lambda t: ["evaluate", route_file(t, format="geojson"), "--target", L],
                                       ["route.json", "format"]),
    "route file without waypoints": (lambda t: ["evaluate", route_file(t, waypoints=[]), "--target", L],
                                     ["route.json", "no waypoints"]),
    "route file with NaN coordinates": (
        lambda t: ["evaluate", route_file(t, raw=route_file(t).read_text().replace("[0, 0, 5]", "[0, NaN, 5]")),
                   "--target", L], ["route.json", "waypoint 0 position"]),
    "route file that is not JSON": (lambda t: ["evaluate", route_file(t, raw="{not json"), "--target", L],
                                    ["route.json", "json"]),
    "broken CityGML": (lambda t: ["plan", file_with(t, "b.gml", "<CityModel><cityObjectMember>"), *PLAN,
                                  "-o", t / "r.json"], ["b.gml", "not well-formed xml"]),
    "broken CityJSON": (lambda t: ["plan", file_with(t, "b.city.json", '{"type": "CityJSON", "CityObjects": {'), *PLAN,
                                   "-o", t / "r.json"], ["b.city.json", "not valid json"]),
    "unknown building id": (lambda t: ["plan", CITY / "lod2_buildings_v3.gml.gz", "--building", "NOPE", *PLAN,
                                       "-o", t / "r.json"], ["no city object with id", "FZK_GUID_"]),
    "unsupported LoD": (lambda t: ["plan", CITY / "lod2_buildings_v3.gml.gz", "--building", HOUSE, "--lod", "0", *PLAN,
                                   "-o", t / "r.json"], ["unsupported lod 0"]),
    "geographic export without a CRS": (lambda t: ["plan", L, *PLAN, "--export", "kml", "-o", t / "r.json"],
                                        ["georeference", "--crs"]),
    "output exists": (lambda t: ["plan", L, *PLAN, "-o", file_with(t, "r.json", "{}")], ["--force"]),
    "mission without camera, GSD or security": (
        lambda t: ["evaluate", file_with(t, "m.plan", "{}"), "--target", L], ["m.plan", "--gsd", "--camera"]),
    "mission that is not a mission": (
        lambda t: ["evaluate", file_with(t, "m.plan", '{"fileType": "Plan"}'), "--target", L, "--crs", "EPSG:25832",
                   *PLAN], ["m.plan", "not a QGroundControl plan"]),
    "mission of an unknown format": (lambda t: ["evaluate", file_with(t, "m.kml", "<kml/>"), "--target", L, *PLAN],
                                     ["m.kml", "not a route or mission"]),
    "mission beside a scene without georeference": (
        lambda t: ["evaluate", file_with(t, "w.waypoints", "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t48.7\t9.1\t250\t1\n"
                                          "1\t0\t3\t16\t0\t0\t0\t0\t48.7\t9.1\t10\t1\n"),
                   "--target", L, *PLAN], ["no georeference", "--crs"]),
    "batch: no buildings chosen": (lambda t: ["batch", CITY / "lod2_buildings_v2.json.gz", *PLAN, "-o", t / "out"],
                                   ["choose the buildings", "--all"]),
    "batch: nothing matches": (lambda t: ["batch", CITY / "lod2_buildings_v2.json.gz", "--bbox", "500", "500", "600",
                                          "600", *PLAN, "-o", t / "out"], ["no building", "matches --bbox"]),
    "batch: inverted --bbox": (lambda t: ["batch", CITY / "lod2_buildings_v2.json.gz", "--bbox", "5", "5", "1", "1",
                                          *PLAN, "-o", t / "out"], ["xmin < xmax"]),
    "batch: --where without =": (lambda t: ["batch", CITY / "lod2_buildings_v2.json.gz", "--where", "roofType", *PLAN,
                                            "-o", t / "out"], ["attr=value", "roofType"]),
    "batch: not a city file": (lambda t: ["batch", L, "--all", *PLAN, "-o", t / "out"], ["l_prism.obj", "not a city model"]),
    "batch: --workers 0": (lambda t: ["batch", CITY / "lod2_buildings_v2.json.gz", "--all", "--workers", "0", *PLAN,
                                      "-o", t / "out"], ["--workers must be at least 1"]),
    "batch: a DTM that is not there": (lambda t: ["batch", CITY / "lod2_buildings_v2.json.gz", "--all", "--terrain",
                                                  t / "dtm.tif", *PLAN, "-o", t / "out"], ["dtm.tif", "no such DTM file"]),
    "unknown drone": (lambda t: ["plan", L, "--drone", "m4x", "--gsd", "0.004", "--security", "3", "-o", t / "r.json"],
                      ["unknown drone 'm4x'", "m3e"]),
    "--drone with --camera": (lambda t: ["plan", L, "--drone", "m3e", *PLAN, "-o", t / "r.json"],
                              ["--drone m3e brings its camera"]),
    "flight limit too short": (lambda t: ["plan", L, "--drone", "m3e", "--gsd", "0.004", "--security", "3",
                                          "--max-flight-min", "0.2", "-o", t / "r.json"],
                               ["too short to reach the nearest shot and return", "--max-flight-min"]),
    "more waypoints than the app takes": (lambda t: ["export", _long_route(t, 65_537), "--format", "wpml", "--crs",
                                                     "EPSG:25832", "--drone", "m3e"],
                                          ["65537 waypoints", "at most 65536", "--max-flight-min"]),
    "more mission items than PX4 keeps": (lambda t: ["export", _long_route(t, 400), "--format", "qgc", "--crs",
                                                     "EPSG:25832"],
                                          ["602 mission items", "PX4 keeps at most 500", "--max-mission-items 500",
                                           "--firmware ardupilot"]),
    "mission item limit below 8": (lambda t: ["plan", L, *PLAN, "--max-mission-items", "5", "-o", t / "r.json"],
                                   ["max mission items must be a whole number >= 8, got 5"]),
    "negative LP time limit": (lambda t: ["plan", L, *PLAN, "--lp-time-limit", "-5", "-o", t / "r.json"],
                               ["LP time limit (--lp-time-limit) must be >= 0 seconds", "got -5"]),
    "WPML export without a drone": (lambda t: ["export", _long_route(t), "--format", "wpml", "--crs", "EPSG:25832"],
                                    ["needs the drone", "--drone"]),
    "WPML for a drone that flies no WPML": (lambda t: ["export", _long_route(t, 3), "--format", "wpml", "--crs",
                                                       "EPSG:25832", "--drone", "phantom4pro"],
                                            ["does not fly DJI WPML", "litchi"]),
    "EGM96 heights without a height datum": (lambda t: ["export", _long_route(t, 3), "--format", "wpml", "--crs",
                                                        "EPSG:25832", "--drone", "m3e", "--wpml-heights", "egm96"],
                                             ["EGM96 heights need", "datum"]),
    "point cloud with no obstacle points": (lambda t: ["plan", L, *PLAN, "--obstacle-points", _ground_only_las(t),
                                                       "-o", t / "r.json"],
                                            ["ground.las", "has no points of every class but ground and noise"]),
    "footprints without a height": (lambda t: ["plan", file_with(t, "f.geojson", json.dumps(
        {"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {}, "geometry": {
            "type": "Polygon", "coordinates": [[[9.18, 48.77], [9.1801, 48.77], [9.1801, 48.7701], [9.18, 48.77]]]}}]})),
        *PLAN, "-o", t / "r.json"], ["f.geojson holds footprints", "--height-attribute NAME or --height M"]),
    "bad --point-classes": (lambda t: ["plan", L, *PLAN, "--obstacle-points", _ground_only_las(t), "--point-classes",
                                       "trees", "-o", t / "r.json"], ["LAS class numbers", "trees"]),
    "--terrain with --ground": (lambda t: ["plan", L, *PLAN, "--terrain", _dtm(t), "--ground", "0", "-o", t / "r.json"],
                                ["either --terrain or --ground"]),
    "terrain that is not a raster": (lambda t: ["plan", L, *PLAN, "--terrain", file_with(t, "dtm.tif", "no raster"),
                                                "-o", t / "r.json"], ["dtm.tif", "is not a raster"]),
    "terrain that misses the site": (lambda t: ["plan", L, *PLAN, "--terrain", _dtm(t, west=5000.0), "-o", t / "r.json"],
                                     ["dtm.tif", "does not reach the scene"]),
    "georeferenced terrain, models without CRS": (lambda t: ["plan", L, *PLAN, "--terrain", _dtm(t, crs="EPSG:25832"),
                                                             "-o", t / "r.json"], ["is in EPSG:25832", "--crs"]),
    "route planned over terrain, evaluated without": (lambda t: ["evaluate", _terrain_route(t), "--target", L],
                                                      ["planned over the terrain dtm.tif", "--terrain"]),
}


GEO = ["--geo-origin", "52.5", "13.4", "40"]  # the L prism's frame on Earth, for zones in WGS84


def _square(lon: float, lat: float, half: float = 0.0002) -> dict:
    """A GeoJSON polygon: a square of ``half`` degrees about (lon, lat)."""
    ring = [[lon - half, lat - half], [lon + half, lat - half], [lon + half, lat + half], [lon - half, lat + half]]
    return {"type": "Polygon", "coordinates": [ring + ring[:1]]}


def _folder(tmp_path, photos: int = 0, gps: bool = True, focal: bool = True):
    """A folder with ``photos`` tagged photos (a black pixel each), with or without their GPS
    position and focal length."""
    import numpy as np

    from coverplan.sfm.photos import PhotoTags, write_photo
    folder = tmp_path / "photos"
    folder.mkdir()
    nan = float("nan")
    for k in range(photos):
        write_photo(folder / f"p{k}.jpg", np.zeros((8, 8, 3), np.uint8),
                    PhotoTags(f"p{k}.jpg", 8, 8, 52.5 if gps else nan, 13.4 if gps else nan,
                              relative_altitude_m=10.0 if gps else nan, focal_35mm=24.0 if focal else nan))
    return folder


def _plan_with_complex(tmp_path, kind: str):
    items = [{"type": "SimpleItem", "command": 22, "frame": 3, "params": [0, 0, 0, None, 52.5, 13.4, 10.0]},
             {"type": "ComplexItem", "complexItemType": kind}]
    return file_with(tmp_path, "mission.plan", json.dumps({
        "fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
        "mission": {"version": 2, "firmwareType": 12, "vehicleType": 2, "plannedHomePosition": [52.5, 13.4, 30],
                    "items": items}}))


def _zone_file(tmp_path, geometry: dict, **properties):
    return file_with(tmp_path, "zone.geojson", json.dumps({"type": "FeatureCollection", "features": [
        {"type": "Feature", "id": 0, "properties": properties, "geometry": geometry}]}))


def _dtm(tmp_path, west: float = -50.0, crs=None):
    """A flat 100 x 100 m GeoTIFF at z 0 whose west edge is at ``west``."""
    import numpy as np
    import rasterio
    from rasterio.transform import from_origin
    path = tmp_path / "dtm.tif"
    with rasterio.open(path, "w", driver="GTiff", height=50, width=50, count=1, dtype="float32",
                       transform=from_origin(west, 100.0, 2.0, 2.0), crs=crs) as f:
        f.write(np.zeros((50, 50), np.float32), 1)
    return path


def _terrain_route(tmp_path):
    return route_file(tmp_path, params={"gsd_m": 0.004, "security_m": 3.0, "terrain": "dtm.tif"})


def _ground_only_las(tmp_path):
    """A LAS file whose 100 points are all ground (class 2)."""
    import laspy
    import numpy as np
    las = laspy.LasData(laspy.LasHeader(point_format=0, version="1.2"))
    xyz = np.random.default_rng(0).uniform(0, 50, (100, 3))
    las.x, las.y, las.z = xyz.T
    las.classification = np.full(100, 2, np.uint8)
    path = tmp_path / "ground.las"
    las.write(path)
    return path


def _long_route(tmp_path, n: int = 120):
    """A hand-written route of ``n`` waypoints along a line, every other one a photo."""
    wps = [{"position": [2.0 * k, 0, 10], "shot": k % 2 == 1, "heading_deg": 0, "gimbal_pitch_deg": -10,
            "leg": "coverage"} for k in range(n)]
    return route_file(tmp_path, waypoints=wps)


def _big_box(tmp_path):
    path = tmp_path / "hangar.obj"
    box(0, 0, -1, 60, 60, 30).export(path)
    return path


@pytest.mark.parametrize("row", sorted(ROWS))
def test_bad_input_row(capsys, tmp_path, row):
    build, words = ROWS[row]
    code, _out, err = run(capsys, *build(tmp_path))
    assert_one_line_error(code, err, *words)


def test_every_row_is_in_the_manual():
    """docs/usage.md lists each of these bad inputs with what the user sees."""
    manual = (MESHES.parent / "docs" / "usage.md").read_text()
    for row in ROWS:
        assert f"| {row} |" in manual, row


def test_unreachable_surface_is_planned_around_and_reported(capsys, tmp_path):
    """Not an error: the rest is planned, the summary says what is hidden and why."""
    wall = tmp_path / "wall.obj"
    box(0, 0, 0, 16, 8, 10).export(wall)
    shed = tmp_path / "shed.obj"
    box(5, -2.3, 0, 11, -0.3, 6).export(shed)
    code, out, _err = run(capsys, "plan", wall, "--obstacles", shed, *PLAN, "-o", tmp_path / "r.json")
    assert code == 0 and "not covered" in out and "occluded by obstacle 'shed'" in out


def test_wrong_units_are_warned(capsys, tmp_path):
    from coverplan import load_scene
    mm = tmp_path / "mm.obj"
    box(0, 0, 0, 12000, 9000, 25000).export(mm)  # a house in millimetres, read as metres
    assert any("pass --units mm" in n for n in load_scene(mm).notes)
    assert not any("WARNING" in n for n in load_scene(mm, units="mm").notes)
    code, out, _err = run(capsys, "plan", mm, *PLAN, "--units", "mm", "-o", tmp_path / "r.json", "-q")
    assert code == 0


def test_argparse_errors_are_one_line_too(capsys, tmp_path):
    code, _, err = run(capsys, "plan", L, "--camera", "phantom4pro", "--security", "3", "-o", tmp_path / "r.json")
    assert_one_line_error(code, err, "--gsd")


def test_real_process_prints_no_traceback(tmp_path):
    """Through a real process, as a user runs it."""
    bad = tmp_path / "broken.obj"
    bad.write_text("f 1 2 3\n")
    proc = subprocess.run([sys.executable, "-m", "coverplan.cli", "evaluate", str(tmp_path / "x.json"),
                           "--target", str(bad)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
