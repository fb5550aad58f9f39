"""DJI WPML missions (.kmz) for DJI Pilot 2 and FlightHub 2: ``wpmz/template.kml`` and
``wpmz/waylines.wpml`` as DJI's public WPML reference (Cloud API documentation) describes them.

One waypoint per route waypoint, none dropped. Where the route stops
(toPointAndStopWithDiscontinuityCurvature) the aircraft flies the planner's straight, checked
segments, and at a photo the action group turns the aircraft to its heading, the gimbal to
its pitch, and takes the photo. Where the route flies through (flight/passing.py) the
waypoint "turns before the waypoint, flies through" (toPointAndPassWithContinuityCurvature
with useStraightLine 1 and the turn's damping distance, whose cut corner the planner checked);
the gimbal turns to the photo's pitch along the leg that arrives there (gimbalEvenlyRotate,
triggered betweenAdjacentPoints) and the photo is taken on reaching the point. Headings turn
evenly along each leg to the next waypoint's (smoothTransition). Each leg's waypointSpeed is
the cruise speed, slowed to the pass speed of an end flown through. The flight ends at the start point, directly above the take-off point, and
lands there (finishAction autoLand); on signal loss it carries on with the mission
(exitOnRCLost goContinue), whose every segment is known to be safe.

Heights (``heights``): "relative" (default) to the take-off point (relativeToStartPoint),
or "egm96": template heights above the EGM96 geoid, executed as WGS84 ellipsoidal heights;
that needs a scene with a height datum and PROJ's geoid grids (geo.ellipsoidal_and_egm96).
"""

from __future__ import annotations

import io
import math
import time
import zipfile
from pathlib import Path

import numpy as np
from lxml import etree

from coverplan.equipment.drones import get_drone
from coverplan.errors import InputFileError, ParameterError
from coverplan.files import write_atomic_bytes
from coverplan.flight.missions import TAKEOFF, MissionBuilder, mission_number
from coverplan.flight.speeds import leg_speeds
from coverplan.geometry.geo import ellipsoidal_and_egm96
from coverplan.geometry.orientation import heading_change_deg
from coverplan.io.geoflight import geo_flight
from coverplan.io.registry import register_mission_reader, register_writer

KML = "http://www.opengis.net/kml/2.2"
WPML = "http://www.dji.com/wpmz/1.0.2"
HEIGHT_MODES = ("relative", "egm96")
# A flight is one WPML file: DJI numbers its waypoints 0..65535 (wpml:index). Litchi's 99 (DJI
# Mobile SDK missions) is met by its own writer, which splits a flight (io/litchi.py).
WPML_WAYPOINTS = 65536


def _w(tag: str) -> str:
    return f"{{{WPML}}}{tag}"


def _add(parent, tag: str, text=None, kml: bool = False):
    el = etree.SubElement(parent, f"{{{KML}}}{tag}" if kml else _w(tag))
    if text is not None:
        el.text = _text(text)
    return el


def _text(v) -> str:
    if isinstance(v, (bool, np.bool_)):
        return "1" if v else "0"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return f"{float(v):.3f}".rstrip("0").rstrip(".") or "0"
    return str(v)


def signed_heading(deg) -> np.ndarray:
    """Degrees clockwise from north in [-180, 180), as WPML wants them.

    Parameters
    ----------
    deg : array_like of float
        Degrees clockwise from north.

    Returns
    -------
    ndarray of float
        Degrees in [-180, 180).
    """
    return heading_change_deg(0.0, deg)


def _drone_for(route, drone):
    name = drone or route.params.get("drone")
    if not name:
        raise ParameterError("WPML export needs the drone: plan (or export) with --drone "
                             "(see 'coverplan drones'; m3e and m350-p1 fly WPML missions)")
    profile = get_drone(name) if isinstance(name, str) else name
    if profile.wpml is None:
        raise ParameterError(f"the {profile.label} does not fly DJI WPML missions (its app: "
                             f"{', '.join(profile.apps)}); choose another --export format")
    return profile


def _heights(route, f, heights: str):
    """(template height, template ellipsoid height, executed height, template mode, executed mode)."""
    if heights == "relative":
        rel = f.alt_rel  # above the take-off point; the ellipsoid height field repeats it (no datum used)
        return rel, rel, rel, "relativeToStartPoint", "relativeToStartPoint"
    if heights == "egm96":
        _lon, _lat, h_ell, h_egm = ellipsoidal_and_egm96(route.frame, route.positions)
        return h_egm, h_ell, h_ell, "EGM96", "WGS84"
    raise ParameterError(f"WPML heights must be one of {', '.join(HEIGHT_MODES)}, got {heights!r}")


def _mission_config(doc, profile, f, speed: float, rth_height: float) -> None:
    cfg = _add(doc, "missionConfig")
    _add(cfg, "flyToWaylineMode", "safely")
    _add(cfg, "finishAction", "autoLand")
    _add(cfg, "exitOnRCLost", "goContinue")
    _add(cfg, "executeRCLostAction", "hover")
    _add(cfg, "takeOffSecurityHeight", max(1.2, round(float(f.alt_rel[0]), 1)))
    _add(cfg, "globalTransitionalSpeed", speed)
    _add(cfg, "globalRTHHeight", rth_height)
    drone_enum, sub_enum, payload_enum = profile.wpml
    info = _add(cfg, "droneInfo")
    _add(info, "droneEnumValue", drone_enum)
    _add(info, "droneSubEnumValue", sub_enum)
    payload = _add(cfg, "payloadInfo")
    _add(payload, "payloadEnumValue", payload_enum)
    _add(payload, "payloadPositionIndex", 0)


def _heading_param(parent, heading: float) -> None:
    hp = _add(parent, "waypointHeadingParam")
    _add(hp, "waypointHeadingMode", "smoothTransition")
    _add(hp, "waypointHeadingAngle", round(float(heading), 2))
    _add(hp, "waypointPoiPoint", "0.000000,0.000000,0.000000")
    _add(hp, "waypointHeadingPathMode", "followBadArc")


def _group(parent, group_id: int, start: int, end: int, trigger: str, steps) -> None:
    group = _add(parent, "actionGroup")
    _add(group, "actionGroupId", group_id)
    _add(group, "actionGroupStartIndex", start)
    _add(group, "actionGroupEndIndex", end)
    _add(group, "actionGroupMode", "sequence")
    _add(_add(group, "actionTrigger"), "actionTriggerType", trigger)
    for action_id, (func, params) in enumerate(steps):
        action = _add(group, "action")
        _add(action, "actionId", action_id)
        _add(action, "actionActuatorFunc", func)
        fp = _add(action, "actionActuatorFuncParam")
        for tag, value in params:
            _add(fp, tag, value)


def _photo_step(photo: int, lens: str):
    return ("takePhoto", [("payloadPositionIndex", 0), ("fileSuffix", f"coverplan{photo:04d}"),
                          ("payloadLensIndex", lens), ("useGlobalPayloadLensIndex", 0)])


def _actions(parent, group_id: int, index: int, heading: float, pitch: float, prev_heading: float, photo: int,
             lens: str) -> None:
    """At a stop: turn to the heading, the gimbal to the pitch, take the photo."""
    turn = heading_change_deg(prev_heading, heading)
    steps = [("rotateYaw", [("aircraftHeading", round(float(heading), 2)),
                            ("aircraftPathMode", "clockwise" if turn >= 0 else "counterClockwise")]),
             ("gimbalRotate", [("gimbalHeadingYawBase", "north"), ("gimbalRotateMode", "absoluteAngle"),
                               ("gimbalPitchRotateEnable", 1), ("gimbalPitchRotateAngle", round(float(pitch), 2)),
                               ("gimbalRollRotateEnable", 0), ("gimbalRollRotateAngle", 0),
                               ("gimbalYawRotateEnable", 0), ("gimbalYawRotateAngle", 0),
                               ("gimbalRotateTimeEnable", 0), ("gimbalRotateTime", 0),
                               ("payloadPositionIndex", 0)]),
             _photo_step(photo, lens)]
    _group(parent, group_id, index, index, "reachPoint", steps)


def _turn_param(parent, passing: bool, damping: float) -> None:
    turn = _add(parent, "waypointTurnParam")
    if passing:  # "turns before the waypoint, flies through" (DJI WPML common elements)
        _add(turn, "waypointTurnMode", "toPointAndPassWithContinuityCurvature")
        _add(turn, "waypointTurnDampingDist", round(float(damping), 3))
    else:
        _add(turn, "waypointTurnMode", "toPointAndStopWithDiscontinuityCurvature")
        _add(turn, "waypointTurnDampingDist", 0)


def _placemark(folder, k, f, heading, executed: bool, heights, speed, action_state, lens, passes) -> None:
    pm = etree.SubElement(folder, f"{{{KML}}}Placemark")
    point = _add(pm, "Point", kml=True)
    _add(point, "coordinates", f"{f.lon[k]:.9f},{f.lat[k]:.9f}", kml=True)
    _add(pm, "index", k)
    height, ellipsoid, execute = heights
    passing, damping, leg_speed = passes[0][k], passes[1][k], passes[2][k]
    if executed:
        _add(pm, "executeHeight", round(float(execute[k]), 3))
        _add(pm, "waypointSpeed", round(float(leg_speed), 3))
        _heading_param(pm, heading[k])
        _turn_param(pm, passing, damping)
        _add(pm, "useStraightLine", 1)
    else:
        _add(pm, "useGlobalHeight", 0)
        _add(pm, "ellipsoidHeight", round(float(ellipsoid[k]), 3))
        _add(pm, "height", round(float(height[k]), 3))
        if passes[3]:
            _add(pm, "useGlobalSpeed", 0)
            _add(pm, "waypointSpeed", round(float(leg_speed), 3))
        else:
            _add(pm, "useGlobalSpeed", 1)
        _add(pm, "useGlobalHeadingParam", 0)
        _heading_param(pm, heading[k])
        if passing:
            _add(pm, "useGlobalTurnParam", 0)
            _turn_param(pm, passing, damping)
        else:
            _add(pm, "useGlobalTurnParam", 1)
        _add(pm, "useStraightLine", 1)
        _add(pm, "gimbalPitchAngle", round(float(f.pitch[k]), 2))
    if f.shot[k]:
        if passing:  # heading by smoothTransition, pitch along the leg: only the photo here
            _group(pm, action_state["group"], k, k, "reachPoint", [_photo_step(action_state["photo"], lens)])
        else:
            prev = heading[k - 1] if k else heading[k]
            _actions(pm, action_state["group"], k, heading[k], f.pitch[k], prev, action_state["photo"], lens)
            action_state["gimbal"] = round(float(f.pitch[k]), 2)
        action_state["group"] += 1
        action_state["photo"] += 1
    last = k + 1 == len(f)
    stop_photo = not last and f.shot[k + 1] and not passes[0][k + 1]
    pitch_next = None if last else round(float(f.pitch[k + 1]), 2)
    if not last and not stop_photo and pitch_next != action_state["gimbal"]:
        # The gimbal reaches the next waypoint's pitch along the leg there, unless a stop with a
        # photo turns it on arrival. Compared with the pitch last commanded, not the previous
        # waypoint's: at take-off the gimbal is wherever the pilot left it.
        _group(pm, action_state["group"], k, k + 1, "betweenAdjacentPoints",
               [("gimbalEvenlyRotate", [("gimbalPitchRotateAngle", pitch_next), ("payloadPositionIndex", 0)])])
        action_state["group"] += 1
        action_state["gimbal"] = pitch_next


def _document(route, f, profile, heights, modes, speed: float, executed: bool) -> bytes:
    root = etree.Element(f"{{{KML}}}kml", nsmap={None: KML, "wpml": WPML})
    doc = etree.SubElement(root, f"{{{KML}}}Document")
    if not executed:
        now = int(time.time() * 1000)
        _add(doc, "author", "coverplan")
        _add(doc, "createTime", now)
        _add(doc, "updateTime", now)
    rth = float(math.ceil(float(np.max(f.alt_rel)) + route.security + 5.0))
    _mission_config(doc, profile, f, speed, rth)
    folder = etree.SubElement(doc, f"{{{KML}}}Folder")
    heading = signed_heading(f.heading_true)
    _add(folder, "templateId", 0)
    if executed:
        _add(folder, "executeHeightMode", modes[1])
        _add(folder, "waylineId", 0)
        _add(folder, "autoFlightSpeed", speed)
    else:
        _add(folder, "templateType", "waypoint")
        sys_param = _add(folder, "waylineCoordinateSysParam")
        _add(sys_param, "coordinateMode", "WGS84")
        _add(sys_param, "heightMode", modes[0])
        _add(sys_param, "positioningType", "GPS")
        _add(folder, "autoFlightSpeed", speed)
        _add(folder, "globalHeight", round(float(heights[0][0]), 3))
        _add(folder, "gimbalPitchMode", "usePointSetting")
        ghp = _add(folder, "globalWaypointHeadingParam")
        _add(ghp, "waypointHeadingMode", "followWayline")
        _add(ghp, "waypointHeadingAngle", 0)
        _add(ghp, "waypointPoiPoint", "0.000000,0.000000,0.000000")
        _add(ghp, "waypointHeadingPathMode", "followBadArc")
        _add(folder, "globalWaypointTurnMode", "toPointAndStopWithDiscontinuityCurvature")
        _add(folder, "globalUseStraightLine", 1)
        payload = _add(folder, "payloadParam")
        _add(payload, "payloadPositionIndex", 0)
        _add(payload, "imageFormat", profile.image_format)
    state = {"group": 0, "photo": 1, "gimbal": None}
    passing = route.passing()
    damping = route.turn_damping if route.turn_damping is not None else np.zeros(len(f))
    passes = (passing, damping, leg_speeds(route, speed), route.flies_through)
    for k in range(len(f)):
        _placemark(folder, k, f, heading, executed, heights, speed, state, profile.image_format, passes)
    return etree.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True)


def wpml_files(route, drone=None, speed: float | None = None, heights: str = "relative") -> dict[str, bytes]:
    """The two XML files of the mission, by their path inside the .kmz.

    Parameters
    ----------
    route : Route
        The route (one battery flight).
    drone : DroneProfile or str, optional
        The drone; the route's when None.
    speed : float, optional
        Cruise speed, m/s.
    heights : {"relative", "egm96"}
        How heights are written.

    Returns
    -------
    dict of str to bytes
        ``template.kml`` and ``waylines.wpml``.
    """
    profile = _drone_for(route, drone)
    speed = float(speed if speed is not None else profile.cruise_speed)
    if not 0 < speed <= min(profile.max_speed, 15.0):
        raise ParameterError(f"WPML speed must be in (0, {min(profile.max_speed, 15.0):g}] m/s, got {speed:g}")
    f = geo_flight(route)
    h_template, h_ellipsoid, h_execute, mode_t, mode_x = _heights(route, f, heights)
    hs = (h_template, h_ellipsoid, h_execute)
    return {"wpmz/template.kml": _document(route, f, profile, hs, (mode_t, mode_x), speed, executed=False),
            "wpmz/waylines.wpml": _document(route, f, profile, hs, (mode_t, mode_x), speed, executed=True)}


def waypoint_fit(route, **_ignored) -> str | None:
    """Why a flight does not fit one WPML file (None: it fits): DJI numbers its waypoints
    0..65535 (wpml:index).

    Parameters
    ----------
    route : Route
        One battery flight.
    **_ignored
        Options of other writers.

    Returns
    -------
    str or None
        The reason.
    """
    if len(route) <= WPML_WAYPOINTS:
        return None
    return (f"{len(route)} waypoints, but wpml missions take at most {WPML_WAYPOINTS}; plan shorter flights "
            "(--max-flight-min) or export another format")


@register_writer("wpml", ".kmz", check=waypoint_fit)
def write_wpml(route, path, drone=None, speed: float | None = None, wpml_heights: str = "relative",
               **_ignored) -> list[Path]:
    """Write the route as a DJI WPML ``.kmz`` for DJI Pilot 2 and FlightHub 2.

    Parameters
    ----------
    route : Route
        The route (one battery flight).
    path : str or Path
        The file.
    drone : DroneProfile or str, optional
        The drone; the route's when None.
    speed : float, optional
        Cruise speed, m/s.
    wpml_heights : {"relative", "egm96"}
        How heights are written.
    **_ignored
        Options of other writers.

    Returns
    -------
    list of Path
        The file written.
    """
    files = wpml_files(route, drone, speed, wpml_heights)
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED) as kmz:
        for name, data in files.items():
            kmz.writestr(name, data)
    return [write_atomic_bytes(path, buffer.getvalue())]


# -- reading, for the evaluator ------------------------------------------------------------

@register_mission_reader("kmz")
def read_wpml(path):
    """A DJI WPML .kmz as a Mission: the executable waylines.wpml's waylines one after another
    (a mapping3d oblique mission has five), heights relative to the take-off point.

    Photos: where a takePhoto action is reached, with the heading of the group's rotateYaw
    (else the waypoint's heading angle) and the gimbalRotate pitch (or the pitch a
    gimbalEvenlyRotate reaches there); and where an equal-distance or equal-time takePhoto
    (``multipleDistance`` / ``multipleTiming``, as DJI Pilot 2's mapping templates write them)
    fires between its first and last waypoint, the time interval turned into metres at the
    leg's speed. Waypoints flown through (toPointAndPassWithContinuityCurvature) keep their
    turn damping distance, so that the evaluator judges the corners they cut and the photos
    where the aircraft passes.

    Parameters
    ----------
    path : str or Path
        The ``.kmz``.

    Returns
    -------
    Mission
        The flight.
    """
    try:
        with zipfile.ZipFile(path) as kmz:
            data = kmz.read("wpmz/waylines.wpml")
    except zipfile.BadZipFile:
        raise InputFileError(path, "is not a DJI WPML mission (not a zip archive)") from None
    except KeyError:
        raise InputFileError(path, "is not a DJI WPML mission (no wpmz/waylines.wpml inside)") from None
    try:
        root = etree.fromstring(data, parser=etree.XMLParser(resolve_entities=False, no_network=True))
    except etree.XMLSyntaxError as exc:
        raise InputFileError(path, f"wpmz/waylines.wpml is not well-formed XML ({exc})") from None
    ns = {"kml": KML, "wpml": root.nsmap.get("wpml", WPML)}
    folders = root.findall("kml:Document/kml:Folder", ns)
    if not folders:
        raise InputFileError(path, "has no wayline (no Folder in waylines.wpml)")
    b = MissionBuilder(path, "DJI WPML mission")
    for folder in folders:
        mode = folder.findtext("wpml:executeHeightMode", default="", namespaces=ns)
        if mode != "relativeToStartPoint":
            raise InputFileError(path, f"gives heights as {mode or 'nothing'}; only relativeToStartPoint missions can "
                                       "be evaluated (ellipsoidal heights need the geoid at the site)")
        _read_wayline(folder, ns, b, path)
    return b.build()


def _read_wayline(folder, ns, b: MissionBuilder, path) -> None:
    """One wayline's waypoints and photos into ``b``."""
    cruise = mission_number(folder.findtext("wpml:autoFlightSpeed", namespaces=ns))
    pending = {}  # waypoint index -> pitch a gimbalEvenlyRotate reaches there
    interval = None  # an equal-distance photo trigger: {"every": m, "since": m, "until": index}
    for k, pm in enumerate(folder.findall("kml:Placemark", ns)):
        coords = (pm.findtext("kml:Point/kml:coordinates", default="", namespaces=ns) or "").strip().split(",")
        try:
            lon, lat = float(coords[0]), float(coords[1])
            alt = float(pm.findtext("wpml:executeHeight", namespaces=ns))
        except (IndexError, TypeError, ValueError):
            raise InputFileError(path, f"waypoint {len(b.rows) + 1} has no readable coordinates or executeHeight") \
                from None
        if interval is not None and b.rows:
            interval["since"] = b.distance_photos(lat, lon, alt, interval["every"], interval["since"])
        angle = pm.findtext("wpml:waypointHeadingParam/wpml:waypointHeadingAngle", namespaces=ns)
        b.waypoint(lat, lon, alt, TAKEOFF, heading=float(angle) if angle is not None else np.nan)
        b.pitch = pending.pop(k, b.pitch)
        if interval is not None and k >= interval["until"]:
            interval = None
        speed = mission_number(pm.findtext("wpml:waypointSpeed", namespaces=ns))
        if pm.findtext("wpml:waypointTurnParam/wpml:waypointTurnMode", namespaces=ns) == \
                "toPointAndPassWithContinuityCurvature":
            b.flown_through(mission_number(pm.findtext("wpml:waypointTurnParam/wpml:waypointTurnDampingDist", namespaces=ns)),
                            speed)
        groups = pm.findall("wpml:actionGroup", ns)
        timed = ("multipleDistance", "multipleTiming")

        def trigger_of(group):
            return group.findtext("wpml:actionTrigger/wpml:actionTriggerType", default="reachPoint", namespaces=ns)
        # what happens on reaching the point (gimbal, heading, photo) first, then the interval photos
        for group in sorted(groups, key=lambda g: trigger_of(g) in timed):
            trigger = trigger_of(group)
            funcs = [a.findtext("wpml:actionActuatorFunc", namespaces=ns) for a in group.findall("wpml:action", ns)]
            if trigger in timed:
                value = mission_number(group.findtext("wpml:actionTrigger/wpml:actionTriggerParam", namespaces=ns))
                leg_speed = speed if np.isfinite(speed) else cruise
                every = value if trigger == "multipleDistance" else value * leg_speed
                if "takePhoto" in funcs and np.isfinite(every) and every > 0:
                    until = mission_number(group.findtext("wpml:actionGroupEndIndex", namespaces=ns))
                    interval = {"every": float(every), "since": 0.0,
                                "until": int(until) if np.isfinite(until) else 1 << 30}
                    b.photo()  # the first photo where the trigger starts
                continue
            for action in group.findall("wpml:action", ns):
                _reach_action(action, group, ns, b, pending)


def _reach_action(action, group, ns, b: MissionBuilder, pending: dict) -> None:
    func = action.findtext("wpml:actionActuatorFunc", namespaces=ns)
    param = action.find("wpml:actionActuatorFuncParam", ns)
    if func == "gimbalEvenlyRotate" and param is not None:
        end = mission_number(group.findtext("wpml:actionGroupEndIndex", namespaces=ns))
        if np.isfinite(end):
            pending[int(end)] = float(param.findtext("wpml:gimbalPitchRotateAngle", default="nan", namespaces=ns))
    elif func == "rotateYaw" and param is not None:
        b.heading = float(param.findtext("wpml:aircraftHeading", default="nan", namespaces=ns))
    elif func == "gimbalRotate" and param is not None and \
            param.findtext("wpml:gimbalPitchRotateEnable", namespaces=ns) == "1":
        b.pitch = float(param.findtext("wpml:gimbalPitchRotateAngle", default="nan", namespaces=ns))
    elif func == "takePhoto":
        b.photo()
