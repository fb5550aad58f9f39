"""QGroundControl: the JSON mission ``.plan`` and the plain ``QGC WPL 110`` waypoint file.

Mission: take-off, then per waypoint a MAV_CMD_NAV_WAYPOINT (yaw = true heading, altitude
relative to home in MAV_FRAME_GLOBAL_RELATIVE_ALT); at shots a gimbal pitch
(MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW) where it differs from the last one set, and one photo
(MAV_CMD_IMAGE_START_CAPTURE); return to launch at the end. NaN parameters are written as
null, as QGroundControl does.

PX4 keeps at most ``PX4_MISSION_ITEMS`` (500) mission items on a flight controller
(NUM_MISSIONS_SUPPORTED in its navigator; only its simulator takes more) and answers a longer
upload with MAV_MISSION_NO_SPACE, so ``export_route`` refuses a longer PX4 .plan; ArduPilot's
limit depends on the board's storage.

A route flown through (flight/passing.py) keeps hold 0 at every waypoint; a waypoint flown
through gets an acceptance radius (param 2): the photo's offset bound at a photo, the turn's
damping distance at a transit point, so the photo is taken within that distance of the
planned point. A MAV_CMD_DO_CHANGE_SPEED before a waypoint sets the leg's speed where it
changes (the cruise speed, slowed to the pass speed of an end flown through).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from coverplan.errors import InputFileError
from coverplan.files import read_json, write_atomic
from coverplan.flight.missions import AMSL, TAKEOFF, MissionBuilder, mission_number
from coverplan.flight.passing import PassRules
from coverplan.flight.speeds import leg_speeds
from coverplan.io.geoflight import geo_flight, geo_zones
from coverplan.io.qgc_complex import expand_complex_item
from coverplan.io.registry import register_mission_reader, register_writer
from coverplan.world.zones import KEEP_IN

NAV_WAYPOINT, NAV_RETURN_TO_LAUNCH, NAV_TAKEOFF = 16, 20, 22
DO_CHANGE_SPEED, SPEED_GROUND = 178, 1
DO_GIMBAL_MANAGER_PITCHYAW, IMAGE_START_CAPTURE = 1000, 2000
FRAME_GLOBAL, FRAME_MISSION, FRAME_GLOBAL_RELATIVE_ALT = 0, 2, 3
FIRMWARE = {"px4": 12, "ardupilot": 3}
MAV_TYPE_QUADROTOR = 2
PX4_MISSION_ITEMS = 500
NAN = float("nan")


def mission_items(route, speed: float = 5.0) -> list[tuple[int, int, list[float]]]:
    """(command, frame, 7 params) for the whole flight, take-off to return.

    Parameters
    ----------
    route : Route
        The route (one battery flight).
    speed : float
        Cruise speed, m/s.

    Returns
    -------
    list of (int, int, list of float)
        MAVLink command, frame and params.
    """
    f = geo_flight(route)
    items = [(NAV_TAKEOFF, FRAME_GLOBAL_RELATIVE_ALT, [0.0, 0.0, 0.0, NAN, f.lat[0], f.lon[0], f.alt_rel[0]])]
    through = route.flies_through
    if through:
        passing = route.passing()
        offset_bound = float((route.metrics.get("fly_through") or {}).get("rules", {}).get(
            "max_photo_offset_m", PassRules().max_photo_offset_m))
        radius = np.where(route.shot, offset_bound, route.turn_damping) * passing
        legs, current = leg_speeds(route, speed), float(speed)
    gimbal = None
    for k in range(1, len(f)):
        if through and abs(legs[k - 1] - current) > 1e-3:
            current = float(legs[k - 1])
            items.append((DO_CHANGE_SPEED, FRAME_MISSION, [SPEED_GROUND, round(current, 3), -1.0, 0.0, 0.0, 0.0, 0.0]))
        accept = round(float(radius[k]), 3) if through else 0.0
        items.append((NAV_WAYPOINT, FRAME_GLOBAL_RELATIVE_ALT,
                      [0.0, accept, 0.0, round(float(f.heading_true[k]), 3), f.lat[k], f.lon[k], f.alt_rel[k]]))
        if f.shot[k]:
            pitch = round(float(f.pitch[k]), 3)
            if pitch != gimbal:  # the gimbal holds its pitch; the first photo always sets it
                items.append((DO_GIMBAL_MANAGER_PITCHYAW, FRAME_MISSION, [pitch, 0.0, NAN, NAN, 0.0, 0.0, 0.0]))
                gimbal = pitch
            items.append((IMAGE_START_CAPTURE, FRAME_MISSION, [0.0, 0.0, 1.0, 0.0, NAN, NAN, NAN]))
    items.append((NAV_RETURN_TO_LAUNCH, FRAME_MISSION, [0.0] * 7))
    return items


def _json_param(v):
    v = float(v)
    return None if math.isnan(v) else v


def px4_fit(route, firmware: str = "px4", speed: float = 5.0, **_ignored) -> str | None:
    """Why a flight's plan does not fit PX4's mission store (None: it fits, or not for PX4).

    Parameters
    ----------
    route : Route
        One battery flight.
    firmware : {"px4", "ardupilot"}
        The autopilot.
    speed : float
        Cruise speed, m/s.
    **_ignored
        Options of other writers.

    Returns
    -------
    str or None
        The reason.
    """
    if firmware != "px4":
        return None
    items = len(mission_items(route, speed))
    if items <= PX4_MISSION_ITEMS:
        return None
    return (f"{items} mission items, but PX4 keeps at most {PX4_MISSION_ITEMS} on a flight controller; plan flights "
            f"that fit (--max-mission-items {PX4_MISSION_ITEMS}, or --max-flight-min) or export another format "
            "(--firmware ardupilot if that is the autopilot)")


@register_writer("qgc", ".plan", check=px4_fit)
def write_plan(route, path, firmware: str = "px4", speed: float = 5.0, **_ignored) -> list[Path]:
    """Write the route as a QGroundControl ``.plan``: simple mission items, its zones as geofences.

    Parameters
    ----------
    route : Route
        The route (one battery flight).
    path : str or Path
        The file.
    firmware : {"px4", "ardupilot"}
        The autopilot the plan is for.
    speed : float
        Cruise speed, m/s.
    **_ignored
        Options of other writers.

    Returns
    -------
    list of Path
        The file written.
    """
    f = geo_flight(route)
    items = []
    for n, (command, frame, params) in enumerate(mission_items(route, speed), start=1):
        items.append({"type": "SimpleItem", "autoContinue": True, "command": command, "doJumpId": n,
                      "frame": frame, "params": [_json_param(p) for p in params]})
    home_alt = f.home[2] if f.home[2] is not None else 0.0
    plan = {
        "fileType": "Plan",
        "version": 1,
        "groundStation": "QGroundControl",
        "mission": {
            "version": 2,
            "firmwareType": FIRMWARE[firmware],
            "vehicleType": MAV_TYPE_QUADROTOR,
            "cruiseSpeed": float(speed),
            "hoverSpeed": float(speed),
            "plannedHomePosition": [f.home[1], f.home[0], home_alt],
            "items": items,
        },
        "geoFence": {"version": 2, "circles": [], "polygons": fence_polygons(route)},
        "rallyPoints": {"version": 2, "points": []},
    }
    return [write_atomic(path, json.dumps(plan, indent=1))]


def fence_polygons(route) -> list[dict]:
    """The zones as QGroundControl geofence polygons: keep-in inclusion, keep-out exclusion.

    A fence is a plan-view polygon from the ground up. A keep-out zone becomes its outline
    (airspace over or under it and inside its holes is fenced off too: stricter than the zone);
    a keep-in zone its outline as inclusion and its holes as exclusions.

    Parameters
    ----------
    route : Route
        The route.

    Returns
    -------
    list of dict
        QGroundControl ``geoFence.polygons`` entries.
    """
    out = []
    for zone in geo_zones(route):
        for rings in zone.polygons:
            inclusion = zone.kind == KEEP_IN
            out.append({"inclusion": inclusion, "polygon": [[float(b), float(a)] for a, b in rings[0]], "version": 1})
            if inclusion:
                out += [{"inclusion": False, "polygon": [[float(b), float(a)] for a, b in hole], "version": 1}
                        for hole in rings[1:]]
    return out


@register_writer("wpl", ".waypoints")
def write_wpl(route, path, speed: float = 5.0, **_ignored) -> list[Path]:
    """Write the route as a ``QGC WPL 110`` text mission (Mission Planner, QGroundControl).

    Parameters
    ----------
    route : Route
        The route (one battery flight).
    path : str or Path
        The file.
    speed : float
        Cruise speed, m/s.
    **_ignored
        Options of other writers.

    Returns
    -------
    list of Path
        The file written.
    """
    f = geo_flight(route)
    home_alt = f.home[2] if f.home[2] is not None else 0.0
    rows = ["QGC WPL 110", _wpl_row(0, 1, FRAME_GLOBAL, NAV_WAYPOINT, [0, 0, 0, 0, f.home[1], f.home[0], home_alt])]
    for n, (command, frame, params) in enumerate(mission_items(route, speed), start=1):
        rows.append(_wpl_row(n, 0, frame, command, params))
    return [write_atomic(path, "\n".join(rows) + "\n")]


def _wpl_row(index, current, frame, command, params) -> str:
    # The text format has no "unset": NaN becomes 0, as Mission Planner writes it.
    params = [0.0 if math.isnan(float(p)) else float(p) for p in params]
    values = [f"{p:.8f}" if k in (4, 5) else f"{p:.6f}" for k, p in enumerate(params)]
    return "\t".join([str(index), str(current), str(frame), str(command), *values, "1"])


# -- reading: missions from QGroundControl / Mission Planner, for the evaluator -------------

NAV_LAND, NAV_LOITER_TIME, CONDITION_YAW = 21, 19, 115
DO_DIGICAM_CONTROL, DO_MOUNT_CONTROL, DO_SET_CAM_TRIGG_DIST = 203, 205, 206
_TAKEOFF_FRAMES = {3, 6}  # MAV_FRAME_GLOBAL_RELATIVE_ALT(_INT): above home
_AMSL_FRAMES = {0, 5}  # MAV_FRAME_GLOBAL(_INT)
_TERRAIN_FRAMES = {10, 11}
_NAMES = {NAV_WAYPOINT: "waypoint", NAV_TAKEOFF: "take-off", NAV_LAND: "land", NAV_LOITER_TIME: "loiter"}


def walk_items(items, home, path, source: str):
    """The Mission of MAVLink mission items (command, frame, 7 params), in order.

    Positions come from take-off, waypoint, loiter and land items; return-to-launch flies
    back over home at the last height. Photos (IMAGE_START_CAPTURE for one image,
    DO_DIGICAM_CONTROL) are taken at the last position with the last heading (the
    waypoint's yaw or CONDITION_YAW) and gimbal pitch (gimbal manager or mount control).
    A distance trigger (DO_SET_CAM_TRIGG_DIST) takes a photo every so many metres along the
    legs after it, until it is set to 0.

    Parameters
    ----------
    items : list of (int, int, list of float)
        Command, frame and params.
    home : (float, float)
        Latitude and longitude.
    path : str or Path
        The mission file, for errors.
    source : str
        What the mission is, for notes.

    Returns
    -------
    Mission
        The flight.
    """

    b = MissionBuilder(path, source)
    home_lat, home_lon = home
    trigger = {"every": 0.0, "since": 0.0}
    for n, (command, frame, params) in enumerate(items, start=1):
        p = [mission_number(v) for v in (list(params) + [None] * 7)[:7]]
        if command in _NAMES and trigger["every"] > 0 and b.rows:
            trigger["since"] = b.distance_photos(p[4], p[5], p[6], trigger["every"], trigger["since"])
        if command in _NAMES:
            if frame in _TERRAIN_FRAMES:
                raise InputFileError(path, f"item {n} gives its height above terrain (frame {frame}); "
                                           "terrain-relative missions are not supported yet")
            if frame not in _TAKEOFF_FRAMES | _AMSL_FRAMES:
                raise InputFileError(path, f"item {n} ({_NAMES[command]}) uses MAVLink frame {frame}; "
                                           "only global frames (0, 3, 5, 6) are supported")
            lat, lon = p[4], p[5]
            if command == NAV_TAKEOFF and (not np.isfinite(lat) or (lat == 0 and lon == 0)):
                lat, lon = home_lat, home_lon  # take off where the vehicle stands
            b.waypoint(lat, lon, p[6], TAKEOFF if frame in _TAKEOFF_FRAMES else AMSL,
                       heading=p[3] if command == NAV_WAYPOINT else np.nan)
        elif command == NAV_RETURN_TO_LAUNCH:
            last = b.rows[-1] if b.rows else None
            if last is not None and np.isfinite(home_lat) and max(abs(last[0] - home_lat), abs(last[1] - home_lon)) > 1e-6:
                b.waypoint(home_lat, home_lon, last[2], last[3])
                b.notes.append("return to launch flown straight back at the last height (the autopilot "
                               "may first climb to its own return altitude)")
        elif command == CONDITION_YAW:
            if p[3] == 0 and np.isfinite(p[0]):  # absolute angle
                b.heading = p[0]
        elif command in (DO_GIMBAL_MANAGER_PITCHYAW, DO_MOUNT_CONTROL):
            if np.isfinite(p[0]):
                b.pitch = p[0]
        elif command == IMAGE_START_CAPTURE:
            if p[2] != 1:
                raise InputFileError(path, f"item {n} starts timed or continuous capture; only single "
                                           "photos (IMAGE_START_CAPTURE with 1 image) can be evaluated")
            b.photo()
        elif command == DO_DIGICAM_CONTROL:
            b.photo()
        elif command == DO_SET_CAM_TRIGG_DIST:
            trigger["every"] = p[0] if np.isfinite(p[0]) and p[0] > 0 else 0.0
            trigger["since"] = 0.0
            if trigger["every"] > 0 and p[2] == 1 and b.rows:  # "trigger once immediately"
                b.photo()
    return b.build(home=home)


@register_mission_reader("plan")
def read_plan(path):
    """A QGroundControl ``.plan`` mission: simple items, and Structure Scans expanded as
    QGroundControl flies them (io/qgc_complex.py).

    Parameters
    ----------
    path : str or Path
        The ``.plan`` file.

    Returns
    -------
    Mission
        The flight.
    """

    data = read_json(path)
    mission = data.get("mission") if isinstance(data, dict) else None
    if not isinstance(mission, dict) or data.get("fileType") != "Plan" or not isinstance(mission.get("items"), list):
        raise InputFileError(path, "is not a QGroundControl plan (no fileType 'Plan' with mission items)")
    home = mission.get("plannedHomePosition") or [None, None, None]
    items = []
    for n, item in enumerate(mission["items"], start=1):
        if not isinstance(item, dict):
            raise InputFileError(path, f"mission item {n} is not an object")
        if item.get("type") == "ComplexItem":
            items += expand_complex_item(item, n, path)
            continue
        params = item.get("params")
        if not isinstance(params, list) or not isinstance(item.get("command"), int):
            raise InputFileError(path, f"mission item {n} has no command and params")
        items.append((item["command"], int(item.get("frame", FRAME_GLOBAL_RELATIVE_ALT)), params))
    return walk_items(items, (mission_number(home[0]), mission_number(home[1])), path, "QGroundControl plan")


@register_mission_reader("waypoints", "txt")
def read_wpl(path):
    """A ``QGC WPL 110`` text mission (QGroundControl, Mission Planner); row 0 is home.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    Mission
        The flight.
    """

    lines = [ln for ln in Path(path).read_text(encoding="utf-8").splitlines() if ln.strip()]
    if not lines or not lines[0].startswith("QGC WPL"):
        raise InputFileError(path, "is not a 'QGC WPL 110' waypoint file (first line)")
    rows = []
    for k, line in enumerate(lines[1:], start=2):
        cells = line.split()
        if len(cells) < 11:
            raise InputFileError(path, f"line {k} has {len(cells)} columns, expected 12")
        try:
            index, _current, frame, command = (int(c) for c in cells[:4])
            params = [float(c) for c in cells[4:11]]
        except ValueError:
            raise InputFileError(path, f"line {k} holds a value that is not a number") from None
        rows.append((index, frame, command, params))
    if not rows or rows[0][0] != 0:
        raise InputFileError(path, "has no home row (index 0)")
    home = (rows[0][3][4], rows[0][3][5])
    items = [(command, frame, params) for _i, frame, command, params in rows[1:]]
    return walk_items(items, home, path, "QGC WPL mission")
