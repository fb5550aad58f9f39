"""`coverplan evaluate` on missions of other apps: our own exports read back, and a
QGroundControl plan written by hand, judged against independent geometry."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pyproj import Transformer

from coverplan import Route, get_camera, load_scene, plan
from coverplan.cli import main
from coverplan.evaluation import evaluate
from coverplan.flight.missions import mission_to_route
from coverplan.io import read_mission
from tests.helpers import MESHES, UTM_BASE, UTM_EAST, UTM_NORTH, utm_house
from tests.independent import polyline_min_distance

CRS = "EPSG:25832"
GSD, SECURITY = 0.004, 3.0
EAST, NORTH, BASE = UTM_EAST, UTM_NORTH, UTM_BASE


def metrics(capsys, argv) -> dict:
    assert main(argv + ["--json"]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    folder = tmp_path_factory.mktemp("missions")
    stem = folder / "gabled"
    assert main([
        "plan", str(MESHES / "gabled_house.obj"), "--camera", "phantom4pro", "--gsd", str(GSD),
        "--security", str(SECURITY), "--crs", CRS, "-o", f"{stem}.json", "--export", "qgc,wpl,litchi",
        "--quiet", "--no-evaluate"]) == 0
    return stem


@pytest.mark.parametrize("suffix", [".plan", ".waypoints", ".litchi.csv"])
def test_exported_missions_evaluate_like_the_route(exported, capsys, suffix):
    scene = ["--target", str(MESHES / "gabled_house.obj"), "--crs", CRS]
    ours = metrics(capsys, ["evaluate", f"{exported}.json", *scene])
    theirs = metrics(capsys, ["evaluate", f"{exported}{suffix}", *scene, "--camera", "phantom4pro",
                              "--gsd", str(GSD), "--security", str(SECURITY)])
    assert theirs["shots"] == ours["shots"]
    assert abs(theirs["coverage_pct"] - ours["coverage_pct"]) <= 0.1
    assert abs(theirs["min_clearance_m"] - ours["min_clearance_m"]) <= 0.01
    assert theirs["safe"] == ours["safe"] and theirs["shot_graph"]["components"] == ours["shot_graph"]["components"]


def test_exported_wpml_evaluates_like_the_route(tmp_path, capsys):
    stem = tmp_path / "gabled"
    assert main(["plan", str(MESHES / "gabled_house.obj"), "--drone", "m3e", "--gsd", str(GSD), "--security",
                 str(SECURITY), "--crs", CRS, "-o", f"{stem}.json", "--export", "wpml", "--quiet",
                 "--no-evaluate"]) == 0
    scene = ["--target", str(MESHES / "gabled_house.obj"), "--crs", CRS]
    ours = metrics(capsys, ["evaluate", f"{stem}.json", *scene])
    theirs = metrics(capsys, ["evaluate", f"{stem}.kmz", *scene, "--camera", "mavic3e", "--gsd", str(GSD),
                              "--security", str(SECURITY)])
    assert theirs["shots"] == ours["shots"]
    assert abs(theirs["coverage_pct"] - ours["coverage_pct"]) <= 0.1
    assert abs(theirs["min_clearance_m"] - ours["min_clearance_m"]) <= 0.01
    assert theirs["safe"] == ours["safe"]


def _utm_to_lonlat(x, y):
    return Transformer.from_crs(CRS, "EPSG:4326", always_xy=True).transform(x, y)


@pytest.fixture
def house(tmp_path):
    """A 10 x 8 x 6 m box placed in UTM coordinates, on ground at 250 m."""
    return utm_house(tmp_path)


def _hand_plan(path, waypoints, frame=3, home=(EAST - 20, NORTH - 20)):
    """A QGroundControl plan as a person would draw it: take-off, waypoints with yaw, then for
    the photos CONDITION_YAW, DO_MOUNT_CONTROL and DO_DIGICAM_CONTROL; return to launch."""
    lon0, lat0 = _utm_to_lonlat(*home)
    items = [{"type": "SimpleItem", "command": 22, "frame": frame, "params": [0, 0, 0, None, 0, 0, 8.0]}]
    for x, y, alt, yaw, photo in waypoints:
        lon, lat = _utm_to_lonlat(x, y)
        items.append({"type": "SimpleItem", "command": 16, "frame": frame, "params": [0, 0, 0, None, lat, lon, alt]})
        if photo:
            items += [{"type": "SimpleItem", "command": 115, "frame": 2, "params": [yaw, 30, 0, 0, 0, 0, 0]},
                      {"type": "SimpleItem", "command": 205, "frame": 2, "params": [-20, 0, 0, 0, 0, 0, 2]},
                      {"type": "SimpleItem", "command": 203, "frame": 2, "params": [0, 0, 0, 0, 1, 0, 0]}]
    items.append({"type": "SimpleItem", "command": 20, "frame": 2, "params": [0] * 7})
    return _plan_file(path, items, lat0, lon0)


def _plan_file(path, items, lat0, lon0):
    """A ``.plan`` file of these mission items, home at (lat0, lon0) on the ground at BASE."""
    data = {"fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
            "mission": {"version": 2, "firmwareType": 12, "vehicleType": 2, "cruiseSpeed": 5, "hoverSpeed": 5,
                        "plannedHomePosition": [lat0, lon0, BASE], "items": items},
            "geoFence": {"version": 2, "circles": [], "polygons": []}, "rallyPoints": {"version": 2, "points": []}}
    path.write_text(json.dumps(data))
    return path


def test_hand_written_qgc_plan(house, tmp_path, capsys):
    # South of the house, 7 m off the wall, 8 m up: two photos facing north (yaw 0).
    wps = [(EAST - 20, NORTH - 7, 8.0, None, False), (EAST + 2, NORTH - 7, 8.0, 0.0, True),
           (EAST + 8, NORTH - 7, 8.0, 0.0, True), (EAST + 20, NORTH - 7, 8.0, None, False)]
    mission_file = _hand_plan(tmp_path / "hand.plan", wps)
    scene = load_scene(house, crs=CRS)
    route = mission_to_route(read_mission(mission_file), scene, get_camera("phantom4pro"), GSD, SECURITY)
    # Positions: take-off over home, the four waypoints, back over home; heights above the take-off ground.
    expect = np.array([[EAST - 20, NORTH - 20, BASE + 8]] + [[x, y, BASE + a] for x, y, a, _h, _p in wps]
                      + [[EAST - 20, NORTH - 20, BASE + 8]]) - np.asarray(scene.origin)
    np.testing.assert_allclose(route.positions, expect, atol=0.01)
    assert route.shot.tolist() == [False, False, True, True, False, False]
    # CONDITION_YAW 0 is true north; in the UTM grid north differs by the convergence (< 1 deg here).
    assert np.all(np.abs((route.heading_deg[route.shot] + 180) % 360 - 180) < 1.0)
    np.testing.assert_allclose(route.pitch_deg[route.shot], -20.0)

    ev = evaluate(route, scene)
    independent = polyline_min_distance(route.positions, scene.meshes, 0.05)
    assert ev.metrics["min_clearance_m"] == pytest.approx(independent, abs=0.02)
    assert ev.safe and ev.metrics["shots"] == 2
    # Two level photos of the south wall: it is imaged, the other walls are not.
    south = ev.samples.normals[:, 1] < -0.9
    assert (ev.views[south] > 0).mean() > 0.5 and (ev.views[~south] == 0).mean() > 0.9

    # The same through the command line, one line on stderr for the notes, exit 0.
    m = metrics(capsys, ["evaluate", str(mission_file), "--target", str(house), "--crs", CRS,
                         "--camera", "phantom4pro", "--gsd", str(GSD), "--security", str(SECURITY)])
    assert m["shots"] == 2 and m["safe"]


def test_hand_written_plan_too_close_is_unsafe(house, tmp_path):
    wps = [(EAST + 5, NORTH - 2, 3.0, 0.0, True)]  # 2 m from the south wall
    scene = load_scene(house, crs=CRS)
    route = mission_to_route(read_mission(_hand_plan(tmp_path / "close.plan", wps)), scene,
                             get_camera("phantom4pro"), GSD, SECURITY)
    ev = evaluate(route, scene)
    assert not ev.safe
    assert ev.metrics["min_clearance_m"] == pytest.approx(polyline_min_distance(route.positions, scene.meshes, 0.05),
                                                          abs=0.02)


@pytest.mark.parametrize("change, message", [
    (lambda d: d["mission"]["items"].append({"type": "ComplexItem", "complexItemType": "StructureScan"}),
     "(Structure Scan) has no polygon"),
    (lambda d: d["mission"]["items"].append({"type": "ComplexItem", "complexItemType": "survey"}),
     "holds no generated mission items"),
    (lambda d: d["mission"]["items"].append({"type": "ComplexItem", "complexItemType": "FWLanding"}),
     "is a FWLanding item, which coverplan does not expand yet"),
    (lambda d: d["mission"]["items"][1].update(frame=10), "above terrain"),
    (lambda d: d["mission"]["items"][1]["params"].__setitem__(4, 123.0), "not on Earth"),
    (lambda d: d.update(fileType="Other"), "not a QGroundControl plan"),
])
def test_bad_missions_are_refused_in_one_line(house, tmp_path, capsys, change, message):
    path = _hand_plan(tmp_path / "bad.plan", [(EAST - 5, NORTH - 7, 8.0, 0.0, True)])
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data))
    code = main(["evaluate", str(path), "--target", str(house), "--crs", CRS, "--camera", "phantom4pro",
                 "--gsd", str(GSD), "--security", str(SECURITY)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and message in err and "Traceback" not in err and len(err.splitlines()) == 1


DISTANCE, FRONTAL, SIDE, BOTTOM, TOP = 7.0, 2.5, 3.0, 2.0, 6.0


def _structure_scan_plan(path, from_top=False):
    """A QGroundControl Structure Scan of the house, as QGroundControl saves it (item version
    3, its settings only): outline = the house's walls, counter-clockwise as drawn here."""
    outline = [(EAST, NORTH), (EAST + 10, NORTH), (EAST + 10, NORTH + 8), (EAST, NORTH + 8)]
    lon0, lat0 = _utm_to_lonlat(EAST - 20, NORTH - 20)
    scan = {"type": "ComplexItem", "complexItemType": "StructureScan", "version": 3,
            "polygon": [list(_utm_to_lonlat(x, y))[::-1] for x, y in outline],
            "EntranceAltitude": 15.0, "ScanBottomAlt": BOTTOM, "StructureHeight": TOP, "Layers": 9,
            "GimbalPitch": 0.0, "StartFromTop": from_top,
            "CameraCalc": {"CameraName": "Custom Camera", "DistanceToSurface": DISTANCE, "DistanceMode": 1,
                           "AdjustedFootprintFrontal": FRONTAL, "AdjustedFootprintSide": SIDE,
                           "FrontalOverlap": 70, "SideOverlap": 70, "ValueSetIsDistance": True, "version": 1}}
    items = [{"type": "SimpleItem", "command": 22, "frame": 3, "params": [0, 0, 0, None, 0, 0, 10.0]}, scan,
             {"type": "SimpleItem", "command": 20, "frame": 2, "params": [0] * 7}]
    return _plan_file(path, items, lat0, lon0)


@pytest.mark.parametrize("from_top", [False, True])
def test_structure_scan_is_flown_as_qgroundcontrol_computes_it(house, tmp_path, capsys, from_top):
    """Layers: ceil((6 - 2) / 2.5) = 2, at 2 + 1.25 and 2 + 3.75 m (from the top: 6 - 1.25 and
    6 - 3.75), each once round the outline offset by 7 m; a photo every 3 m of each loop,
    the first at its start; the camera level and facing the wall."""
    scene = load_scene(house, crs=CRS)
    mission = read_mission(_structure_scan_plan(tmp_path / "scan.plan", from_top))
    route = mission_to_route(mission, scene, get_camera("phantom4pro"), GSD, SECURITY)
    shots = route.positions[route.shots]
    heights = np.unique(np.round(shots[:, 2] - BASE, 3))
    expected = [TOP - 1.25, TOP - 3.75] if from_top else [BOTTOM + 1.25, BOTTOM + 3.75]
    assert heights.tolist() == pytest.approx(sorted(expected), abs=0.01)
    first_layer = shots[0, 2] - BASE
    assert first_layer == pytest.approx(expected[0], abs=0.01)
    loop = 2 * (10 + 8) + 8 * DISTANCE  # the outline offset by 7 m with mitred corners
    assert len(shots) == 2 * (int(loop // SIDE) + 1)
    # Every photo 7 m from the walls' plane it faces (on the straight parts), or farther at the corners.
    lo, hi = np.array([EAST, NORTH]), np.array([EAST + 10, NORTH + 8])
    local = shots[:, :2] + np.asarray(scene.origin[:2])
    outside = np.maximum(np.maximum(lo - local, local - hi), 0.0)
    assert (outside.max(axis=1) >= DISTANCE - 0.05).all() and (outside.max(axis=1) <= DISTANCE + 0.05).all()
    # Level camera, 90 deg right of the way flown, which is clockwise round the house: it looks at the house.
    assert np.allclose(route.pitch_deg[route.shots], 0.0)
    view = np.column_stack([np.sin(np.radians(route.heading_deg[route.shots])),
                            np.cos(np.radians(route.heading_deg[route.shots]))])
    centre = (lo + hi) / 2.0
    assert (np.einsum("ij,ij->i", view, centre - local) > 0).all()
    # Entrance and exit at the first vertex at 15 m; evaluated like any mission.
    assert route.positions[1, 2] - BASE == pytest.approx(15.0, abs=0.01)
    m = metrics(capsys, ["evaluate", str(tmp_path / "scan.plan"), "--target", str(house), "--crs", CRS,
                         "--camera", "phantom4pro", "--gsd", str(GSD), "--security", str(SECURITY)])
    assert m["shots"] == len(shots)
    # From the top, QGroundControl counts the layers down from the structure's height: the
    # second one, at 2.25 m, is below the 3 m minimum altitude, and the evaluator says so.
    assert m["safe"] == (not from_top) and (m["altitude_violations"] > 0) == from_top
    assert m["coverage_by_class_pct"]["facade"] > m["coverage_by_class_pct"].get("roof", 0.0)


def test_plan_adds_to_a_structure_scan_what_it_misses(house, tmp_path, capsys):
    """The scan flies level layers round the walls: ``plan --existing`` on its .plan adds the
    roof, and the scan's photos with the new ones cover the house in one photo set."""
    scan = _structure_scan_plan(tmp_path / "scan.plan")
    alone = metrics(capsys, ["evaluate", str(scan), "--target", str(house), "--crs", CRS, "--camera", "phantom4pro",
                             "--gsd", str(GSD), "--security", str(SECURITY)])
    out = tmp_path / "more.json"
    assert main(["plan", str(house), "--crs", CRS, "--camera", "phantom4pro", "--gsd", str(GSD), "--security",
                 str(SECURITY), "--existing", str(scan), "-o", str(out), "-q", "--no-evaluate"]) == 0
    more = Route.load(out)
    assert more.params["existing_photos"]["count"] == alone["shots"]
    assert (more.pitch_deg[more.shot] <= -45.0).any()  # looking down at the roof
    both = metrics(capsys, ["evaluate", str(out), "--target", str(house), "--crs", CRS])
    assert alone["coverage_by_class_pct"].get("roof", 0.0) < 50.0
    assert both["coverage_by_class_pct"]["roof"] >= 99.0 and both["coverage_pct"] >= 99.0
    assert both["shot_graph"]["components"] == 1 and both["safe"]


SURVEY_ALT, TRIGGER = 25.0, 4.0


def _survey_plan(path):
    """A QGroundControl Survey over the house as QGroundControl saves it: its settings and the
    mission items it generated (TransectStyleComplexItem.Items), here two transects running
    north over the roof 6 m apart with the camera triggered every 4 m along them."""
    def wp(x, y):
        lon, lat = _utm_to_lonlat(x, y)
        return {"type": "SimpleItem", "command": 16, "frame": 3, "autoContinue": True,
                "params": [0, 0, 0, None, lat, lon, SURVEY_ALT]}

    def trigger(distance):
        return {"type": "SimpleItem", "command": 206, "frame": 2, "autoContinue": True,
                "params": [distance, 0, 1 if distance else 0, 0, 0, 0, 0]}
    x0, x1 = EAST + 2, EAST + 8
    generated = [wp(x0, NORTH - 7), trigger(TRIGGER), wp(x0, NORTH + 15), trigger(0),
                 wp(x1, NORTH + 15), trigger(TRIGGER), wp(x1, NORTH - 7), trigger(0)]
    polygon = [list(_utm_to_lonlat(x, y))[::-1] for x, y in
               [(EAST, NORTH), (EAST + 10, NORTH), (EAST + 10, NORTH + 8), (EAST, NORTH + 8)]]
    survey = {"type": "ComplexItem", "complexItemType": "survey", "version": 5, "angle": 0, "polygon": polygon,
              "TransectStyleComplexItem": {"version": 2, "TurnAroundDistance": 6, "CameraTriggerInTurnAround": False,
                                           "HoverAndCapture": False, "Refly90Degrees": False, "CameraShots": 12,
                                           "CameraCalc": {"DistanceToSurface": SURVEY_ALT},
                                           "VisualTransectPoints": [], "Items": generated}}
    lon0, lat0 = _utm_to_lonlat(EAST - 20, NORTH - 20)
    items = [{"type": "SimpleItem", "command": 22, "frame": 3, "params": [0, 0, 0, None, 0, 0, 10.0]}, survey,
             {"type": "SimpleItem", "command": 20, "frame": 2, "params": [0] * 7}]
    return _plan_file(path, items, lat0, lon0)


def test_a_survey_is_flown_as_qgroundcontrol_saved_it(house, tmp_path, capsys):
    """Photos every 4 m along each 22 m transect, the first where the trigger starts (0, 4, ...
    20 m: 6 a transect), none on the turn; the camera straight down."""
    scene = load_scene(house, crs=CRS)
    route = mission_to_route(read_mission(_survey_plan(tmp_path / "survey.plan")), scene,
                             get_camera("phantom4pro"), GSD, SECURITY)
    shots = route.positions[route.shots]
    assert len(shots) == 12
    assert np.allclose(route.pitch_deg[route.shots], -90.0)
    local = shots[:, :2] + np.asarray(scene.origin[:2])
    for x in (EAST + 2, EAST + 8):
        lane = np.sort(local[np.abs(local[:, 0] - x) < 0.05, 1])
        assert len(lane) == 6 and np.allclose(np.diff(lane), TRIGGER, atol=0.05)
    assert np.allclose(shots[:, 2] - BASE, SURVEY_ALT, atol=0.01)
    m = metrics(capsys, ["evaluate", str(tmp_path / "survey.plan"), "--target", str(house), "--crs", CRS,
                         "--camera", "phantom4pro", "--gsd", "0.01", "--security", str(SECURITY)])
    assert m["shots"] == 12 and m["coverage_by_class_pct"]["roof"] > m["coverage_by_class_pct"]["facade"]


def test_amsl_mission_needs_a_height_datum(house, tmp_path, capsys):
    path = _hand_plan(tmp_path / "amsl.plan", [(EAST - 5, NORTH - 7, BASE + 8.0, 0.0, True)], frame=0)
    code = main(["evaluate", str(path), "--target", str(house), "--crs", CRS, "--camera", "phantom4pro",
                 "--gsd", str(GSD), "--security", str(SECURITY)])
    assert code == 2 and "above sea level" in capsys.readouterr().err


def test_mission_needs_camera_gsd_and_security(house, tmp_path, capsys):
    path = _hand_plan(tmp_path / "m.plan", [(EAST - 5, NORTH - 7, 8.0, 0.0, True)])
    assert main(["evaluate", str(path), "--target", str(house), "--crs", CRS]) == 2
    err = capsys.readouterr().err
    assert "--gsd" in err and "--camera" in err


def test_route_waypoints_without_photo_need_no_orientation(tmp_path):
    scene = load_scene(MESHES / "gabled_house.obj")
    route = plan(scene, get_camera("thesis80"), gsd=0.01, security=SECURITY)
    data = route.to_dict()
    for wp in data["waypoints"]:
        if not wp["shot"]:
            for key in ("view_dir", "heading_deg", "gimbal_pitch_deg"):
                wp.pop(key)
    path = tmp_path / "bare.json"
    path.write_text(json.dumps(data))
    again = evaluate(Route.load(path), scene)
    assert again.coverage_pct == pytest.approx(evaluate(route, scene).coverage_pct)
    shot = next(wp for wp in data["waypoints"] if wp["shot"])
    for key in ("view_dir", "heading_deg", "gimbal_pitch_deg"):
        shot.pop(key)
    path.write_text(json.dumps(data))
    with pytest.raises(Exception, match="is a photo but has neither"):
        Route.load(path)
