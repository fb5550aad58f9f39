"""DJI WPML .kmz: unzipped and parsed with lxml, checked against the elements DJI's WPML
reference marks required, and round-tripped against the route."""

from __future__ import annotations

import copy
import zipfile

import numpy as np
import pytest
from lxml import etree
from pyproj import Geod

from coverplan import load_scene, plan
from coverplan.equipment.drones import get_drone
from coverplan.errors import ParameterError
from coverplan.geometry.geo import from_lonlat, to_lonlat
from coverplan.io import export_route
from tests.helpers import MESHES

NS = {"kml": "http://www.opengis.net/kml/2.2", "wpml": "http://www.dji.com/wpmz/1.0.2"}

# Required elements, from DJI's WPML reference (template.kml, waylines.wpml, common elements).
MISSION = ["flyToWaylineMode", "finishAction", "exitOnRCLost", "takeOffSecurityHeight", "globalTransitionalSpeed",
           "droneInfo/wpml:droneEnumValue", "payloadInfo/wpml:payloadEnumValue",
           "payloadInfo/wpml:payloadPositionIndex"]
ENUMS = {"flyToWaylineMode": {"safely", "pointToPoint"},
         "finishAction": {"goHome", "noAction", "autoLand", "gotoFirstWaypoint"},
         "exitOnRCLost": {"goContinue", "executeLostAction"},
         "executeRCLostAction": {"goBack", "landing", "hover"},
         "waypointHeadingMode": {"followWayline", "manually", "fixed", "smoothTransition", "towardPOI"},
         "waypointHeadingPathMode": {"clockwise", "counterClockwise", "followBadArc"},
         "waypointTurnMode": {"coordinateTurn", "toPointAndStopWithDiscontinuityCurvature",
                              "toPointAndStopWithContinuityCurvature", "toPointAndPassWithContinuityCurvature"},
         "executeHeightMode": {"WGS84", "relativeToStartPoint", "realTimeFollowSurface"},
         "heightMode": {"EGM96", "relativeToStartPoint", "aboveGroundLevel", "realTimeFollowSurface"},
         "gimbalPitchMode": {"manual", "usePointSetting"}, "templateType": {"waypoint", "mapping2d", "mapping3d",
                                                                             "mappingStrip"}}
ACTION_PARAMS = {
    "takePhoto": ["payloadPositionIndex", "fileSuffix", "useGlobalPayloadLensIndex"],
    "gimbalRotate": ["payloadPositionIndex", "gimbalHeadingYawBase", "gimbalRotateMode", "gimbalPitchRotateEnable",
                     "gimbalPitchRotateAngle", "gimbalRollRotateEnable", "gimbalRollRotateAngle",
                     "gimbalYawRotateEnable", "gimbalYawRotateAngle", "gimbalRotateTimeEnable", "gimbalRotateTime"],
    "rotateYaw": ["aircraftHeading", "aircraftPathMode"],
}


def one(el, path):
    found = el.findall(path, NS)
    assert len(found) == 1, (path, len(found))
    return found[0].text


def check_required(doc, executed: bool):
    cfg = doc.find("kml:Document/wpml:missionConfig", NS)
    for name in MISSION + (["globalRTHHeight"] if executed else []):
        one(cfg, f"wpml:{name}")
    if one(cfg, "wpml:exitOnRCLost") == "executeLostAction":
        one(cfg, "wpml:executeRCLostAction")
    assert 1.2 <= float(one(cfg, "wpml:takeOffSecurityHeight")) <= 1500
    assert 0 < float(one(cfg, "wpml:globalTransitionalSpeed")) <= 15
    folder = doc.find("kml:Document/kml:Folder", NS)
    folder_required = ["templateId", "autoFlightSpeed"] + (
        ["waylineId", "executeHeightMode"] if executed else
        ["templateType", "waylineCoordinateSysParam/wpml:coordinateMode", "waylineCoordinateSysParam/wpml:heightMode",
         "globalWaypointTurnMode", "gimbalPitchMode", "globalHeight", "payloadParam/wpml:imageFormat",
         "payloadParam/wpml:payloadPositionIndex"])
    for name in folder_required:
        one(folder, f"wpml:{name}")
    if not executed and one(folder, "wpml:globalWaypointTurnMode").endswith("ContinuityCurvature"):
        one(folder, "wpml:globalUseStraightLine")
    for el in doc.iter(f"{{{NS['wpml']}}}*"):
        name = etree.QName(el).localname
        if name in ENUMS:
            assert el.text in ENUMS[name], (name, el.text)
    marks = folder.findall("kml:Placemark", NS)
    assert [int(one(pm, "wpml:index")) for pm in marks] == list(range(len(marks)))
    group_ids = []
    for pm in marks:
        one(pm, "kml:Point/kml:coordinates")
        if executed:
            one(pm, "wpml:executeHeight")
            one(pm, "wpml:waypointSpeed")
            needs_heading, needs_turn = True, True
        else:
            for name in ("useGlobalHeight", "useGlobalSpeed", "useGlobalHeadingParam", "useGlobalTurnParam"):
                assert one(pm, f"wpml:{name}") in ("0", "1")
            if one(pm, "wpml:useGlobalHeight") == "0":
                one(pm, "wpml:ellipsoidHeight")
                one(pm, "wpml:height")
            if one(pm, "wpml:useGlobalSpeed") == "0":
                one(pm, "wpml:waypointSpeed")
            needs_heading = one(pm, "wpml:useGlobalHeadingParam") == "0"
            needs_turn = one(pm, "wpml:useGlobalTurnParam") == "0"
            if one(folder, "wpml:gimbalPitchMode") == "usePointSetting":
                one(pm, "wpml:gimbalPitchAngle")
        if needs_heading:
            mode = one(pm, "wpml:waypointHeadingParam/wpml:waypointHeadingMode")
            one(pm, "wpml:waypointHeadingParam/wpml:waypointHeadingPathMode")
            if mode == "smoothTransition":
                assert -180 <= float(one(pm, "wpml:waypointHeadingParam/wpml:waypointHeadingAngle")) <= 180
        if needs_turn:
            turn = one(pm, "wpml:waypointTurnParam/wpml:waypointTurnMode")
            if turn in ("coordinateTurn", "toPointAndPassWithContinuityCurvature"):
                one(pm, "wpml:waypointTurnParam/wpml:waypointTurnDampingDist")
        for group in pm.findall("wpml:actionGroup", NS):
            group_ids.append(int(one(group, "wpml:actionGroupId")))
            start, end = int(one(group, "wpml:actionGroupStartIndex")), int(one(group, "wpml:actionGroupEndIndex"))
            assert start <= end and one(group, "wpml:actionGroupMode") == "sequence"
            one(group, "wpml:actionTrigger/wpml:actionTriggerType")
            for action in group.findall("wpml:action", NS):
                one(action, "wpml:actionId")
                func = one(action, "wpml:actionActuatorFunc")
                for name in ACTION_PARAMS.get(func, []):
                    one(action, f"wpml:actionActuatorFuncParam/wpml:{name}")
    assert len(set(group_ids)) == len(group_ids)
    return marks


def read_kmz(path):
    with zipfile.ZipFile(path) as kmz:
        assert sorted(kmz.namelist()) == ["wpmz/template.kml", "wpmz/waylines.wpml"]
        return (etree.fromstring(kmz.read("wpmz/template.kml")), etree.fromstring(kmz.read("wpmz/waylines.wpml")))


def actions(pm, func):
    return [a for a in pm.findall("wpml:actionGroup/wpml:action", NS) if one(a, "wpml:actionActuatorFunc") == func]


def held_pitch(marks) -> list:
    """The gimbal pitch at each waypoint as the aircraft executes the actions: a gimbalRotate
    on reaching it, or the end of a gimbalEvenlyRotate along the leg that arrives there."""
    current, pending, out = None, {}, []
    for k, pm in enumerate(marks):
        current = pending.pop(k, current)
        for a in actions(pm, "gimbalRotate"):
            current = float(one(a, "wpml:actionActuatorFuncParam/wpml:gimbalPitchRotateAngle"))
        out.append(current)
        for group in pm.findall("wpml:actionGroup", NS):
            for a in group.findall("wpml:action", NS):
                if one(a, "wpml:actionActuatorFunc") == "gimbalEvenlyRotate":
                    assert one(group, "wpml:actionTrigger/wpml:actionTriggerType") == "betweenAdjacentPoints"
                    pending[int(one(group, "wpml:actionGroupEndIndex"))] = float(
                        one(a, "wpml:actionActuatorFuncParam/wpml:gimbalPitchRotateAngle"))
    return out


@pytest.fixture(scope="module", params=["m3e", "m4e", "m350-p1"])
def mission(request, tmp_path_factory):
    drone = get_drone(request.param)
    scene = load_scene(MESHES / "gabled_house.obj", crs="EPSG:25832")
    route = plan(scene, drone.camera, gsd=0.003 if drone.name == "m3e" else 0.0015, security=2.5, drone=drone)
    out = tmp_path_factory.mktemp(drone.name)
    [path] = export_route(route, out / "house", ["wpml"])
    return drone, route, path


def test_the_first_photo_sets_the_gimbal_even_at_the_start_points_pitch(mission, tmp_path):
    # At take-off the gimbal is wherever the pilot left it: a flight whose photos all look
    # level (the start waypoint's pitch too) must still command that pitch before the first.
    _drone, route, _path = mission
    level = copy.deepcopy(route)
    level.pitch_deg[:] = 0.0
    [path] = export_route(level, tmp_path / "level", ["wpml"])
    marks = read_kmz(path)[1].findall("kml:Document/kml:Folder/kml:Placemark", NS)
    held = held_pitch(marks)
    assert [held[k] for k in np.flatnonzero(level.shot)] == [0.0] * int(level.shot.sum())


def test_wpml_has_every_required_element_and_the_drone(mission):
    drone, route, path = mission
    template, waylines = read_kmz(path)
    for doc, executed in ((template, False), (waylines, True)):
        marks = check_required(doc, executed)
        assert len(marks) == len(route)
        cfg = doc.find("kml:Document/wpml:missionConfig", NS)
        assert (int(one(cfg, "wpml:droneInfo/wpml:droneEnumValue")),
                int(one(cfg, "wpml:droneInfo/wpml:droneSubEnumValue")),
                int(one(cfg, "wpml:payloadInfo/wpml:payloadEnumValue"))) == drone.wpml
    assert one(waylines, "kml:Document/kml:Folder/wpml:executeHeightMode") == "relativeToStartPoint"
    assert one(template, "kml:Document/kml:Folder/wpml:waylineCoordinateSysParam/wpml:heightMode") == \
        "relativeToStartPoint"


def test_wpml_round_trips_positions_headings_and_pitches(mission):
    _drone, route, path = mission
    _template, waylines = read_kmz(path)
    marks = waylines.findall("kml:Document/kml:Folder/kml:Placemark", NS)
    lon, lat = np.array([[float(v) for v in one(pm, "kml:Point/kml:coordinates").split(",")] for pm in marks]).T
    height = np.array([float(one(pm, "wpml:executeHeight")) for pm in marks])
    ground = route.params["ground_z_m"]
    local = from_lonlat(route.frame, lon, lat, height + ground)
    assert np.linalg.norm(local - route.positions, axis=1).max() <= 0.01
    shots = [k for k, pm in enumerate(marks) if actions(pm, "takePhoto")]
    assert shots == list(np.flatnonzero(route.shot))
    suffixes = [one(a, "wpml:actionActuatorFuncParam/wpml:fileSuffix") for k in shots
                for a in actions(marks[k], "takePhoto")]
    assert len(set(suffixes)) == len(shots)
    held = held_pitch(marks)
    pitch = [held[k] for k in shots]
    np.testing.assert_allclose(pitch, route.pitch_deg[route.shot], atol=0.01)
    # True heading, measured independently: the azimuth from each photo position to a point
    # 10 m ahead along its heading in the local grid.
    rows = route.shot
    ahead = route.positions[rows] + 10.0 * np.column_stack([np.sin(np.radians(route.heading_deg[rows])),
                                                            np.cos(np.radians(route.heading_deg[rows])),
                                                            np.zeros(rows.sum())])
    lon0, lat0, _ = to_lonlat(route.frame, route.positions[rows])
    lon1, lat1, _ = to_lonlat(route.frame, ahead)
    azimuth = np.asarray(Geod(ellps="WGS84").inv(lon0, lat0, lon1, lat1)[0])
    yaw = np.array([float(one(actions(marks[k], "rotateYaw")[0], "wpml:actionActuatorFuncParam/wpml:aircraftHeading"))
                    if actions(marks[k], "rotateYaw")  # at a stop; flown through, smoothTransition reaches it
                    else float(one(marks[k], "wpml:waypointHeadingParam/wpml:waypointHeadingAngle")) for k in shots])
    assert np.abs((yaw - azimuth + 180) % 360 - 180).max() <= 0.02
    assert np.all((yaw >= -180) & (yaw <= 180))


def test_egm96_heights_need_the_geoid_grid_or_say_so(tmp_path):
    """With a height datum, EGM96 heights either come out (the geoid is then within +-110 m of
    the ellipsoid) or the export names the PROJ grid it lacks."""
    from coverplan.io.wpml import wpml_files
    scene = load_scene(MESHES / "gabled_house.obj", crs="EPSG:25832")
    drone = get_drone("m3e")
    route = plan(scene, drone.camera, gsd=0.004, security=2.5, drone=drone, lp_time_limit=0)
    route.frame = dict(route.frame, vertical_crs="EPSG:5783")  # DHHN2016 heights
    try:
        files = wpml_files(route, heights="egm96")
    except ParameterError as exc:
        assert ".tif" in str(exc) and "relative" in str(exc)
        return
    template = etree.fromstring(files["wpmz/template.kml"])
    marks = template.findall("kml:Document/kml:Folder/kml:Placemark", NS)
    egm = np.array([float(one(pm, "wpml:height")) for pm in marks])
    ell = np.array([float(one(pm, "wpml:ellipsoidHeight")) for pm in marks])
    assert np.all(np.abs(ell - egm) < 110) and np.ptp(ell - egm) < 1.0


def _oblique_kmz(path, lines, every: float, trigger: str = "multipleDistance", speed: float = 5.0):
    """A DJI Pilot 2 mapping-style waylines.wpml: one Folder per wayline (a mapping3d mission
    has five), each a straight line with its gimbal pitch set on reaching the first point and
    an equal-distance (or equal-time) takePhoto from its first point to its last."""
    W = "http://www.dji.com/wpmz/1.0.2"
    K = "http://www.opengis.net/kml/2.2"
    root = etree.Element(f"{{{K}}}kml", nsmap={None: K, "wpml": W})
    doc = etree.SubElement(root, f"{{{K}}}Document")

    def add(parent, tag, text=None, ns=W):
        el = etree.SubElement(parent, f"{{{ns}}}{tag}")
        if text is not None:
            el.text = str(text)
        return el
    for n, (start, end, pitch) in enumerate(lines):
        folder = add(doc, "Folder", ns=K)
        add(folder, "waylineId", n)
        add(folder, "executeHeightMode", "relativeToStartPoint")
        add(folder, "autoFlightSpeed", speed)
        for k, (lon, lat) in enumerate((start, end)):
            pm = add(folder, "Placemark", ns=K)
            add(add(pm, "Point", ns=K), "coordinates", f"{lon:.9f},{lat:.9f}", ns=K)
            add(pm, "index", k)
            add(pm, "executeHeight", 30)
            if k == 0:
                group = add(pm, "actionGroup")
                add(group, "actionGroupStartIndex", 0)
                add(group, "actionGroupEndIndex", 0)
                add(add(group, "actionTrigger"), "actionTriggerType", "reachPoint")
                action = add(group, "action")
                add(action, "actionActuatorFunc", "gimbalRotate")
                fp = add(action, "actionActuatorFuncParam")
                add(fp, "gimbalPitchRotateEnable", 1)
                add(fp, "gimbalPitchRotateAngle", pitch)
                group = add(pm, "actionGroup")
                add(group, "actionGroupStartIndex", 0)
                add(group, "actionGroupEndIndex", 1)
                tr = add(group, "actionTrigger")
                add(tr, "actionTriggerType", trigger)
                add(tr, "actionTriggerParam", every)
                add(add(group, "action"), "actionActuatorFunc", "takePhoto")
    with zipfile.ZipFile(path, "w") as kmz:
        kmz.writestr("wpmz/waylines.wpml", etree.tostring(root, xml_declaration=True, encoding="UTF-8"))
    return path


@pytest.mark.parametrize("trigger, every", [("multipleDistance", 5.0), ("multipleTiming", 1.0)])
def test_mapping_waylines_take_their_interval_photos(tmp_path, trigger, every):
    """Two waylines 20 m long (north, then east): a photo every 5 m from each first point (the
    equal-time trigger every 1 s at 5 m/s), pitched as each wayline's gimbalRotate says."""
    from coverplan.io import read_mission

    geod = Geod(ellps="WGS84")
    lon0, lat0 = 11.5, 48.1
    lon1, lat1, _ = geod.fwd(lon0, lat0, 0.0, 20.0)
    lon2, lat2, _ = geod.fwd(lon0, lat0, 90.0, 20.0)
    path = _oblique_kmz(tmp_path / "map.kmz", [((lon0, lat0), (lon1, lat1), -45.0), ((lon0, lat0), (lon2, lat2), -90.0)],
                        every, trigger)
    mission = read_mission(path)
    shots = np.flatnonzero(mission.shot)
    assert len(shots) == 8  # at 0, 5, 10 and 15 m of each line
    assert np.allclose(mission.pitch[shots], [-45.0] * 4 + [-90.0] * 4)
    lat, lon = mission.lat[shots], mission.lon[shots]
    _az, _baz, dist = geod.inv(np.full(8, lon0), np.full(8, lat0), lon, lat)
    assert np.allclose(np.sort(dist[:4]), [0, 5, 10, 15], atol=0.01)
    assert np.allclose(np.sort(dist[4:]), [0, 5, 10, 15], atol=0.01)
