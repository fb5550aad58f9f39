"""QGroundControl: the JSON mission ``.plan`` and the plain ``QGC WPL 110`` waypoint file.

Mission: take-off, then per waypoint a MAV_CMD_NAV_WAYPOINT (yaw = true heading, altitude
relative to home in MAV_FRAME_GLOBAL_RELATIVE_ALT); at shots a gimbal pitch
(MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW) and one photo (MAV_CMD_IMAGE_START_CAPTURE); return to
launch at the end. NaN parameters are written as null, as QGroundControl does.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from . import register_writer, write_atomic
from .flight import geo_flight

NAV_WAYPOINT, NAV_RETURN_TO_LAUNCH, NAV_TAKEOFF = 16, 20, 22
DO_GIMBAL_MANAGER_PITCHYAW, IMAGE_START_CAPTURE = 1000, 2000
FRAME_GLOBAL, FRAME_MISSION, FRAME_GLOBAL_RELATIVE_ALT = 0, 2, 3
FIRMWARE = {"px4": 12, "ardupilot": 3}
MAV_TYPE_QUADROTOR = 2
NAN = float("nan")


def mission_items(route) -> list[tuple[int, int, list[float]]]:
    """(command, frame, 7 params) for the whole flight, take-off to return."""
    f = geo_flight(route)
    items = [(NAV_TAKEOFF, FRAME_GLOBAL_RELATIVE_ALT, [0.0, 0.0, 0.0, NAN, f.lat[0], f.lon[0], f.alt_rel[0]])]
    for k in range(1, len(f)):
        items.append((NAV_WAYPOINT, FRAME_GLOBAL_RELATIVE_ALT,
                      [0.0, 0.0, 0.0, round(float(f.heading_true[k]), 3), f.lat[k], f.lon[k], f.alt_rel[k]]))
        if f.shot[k]:
            items.append((DO_GIMBAL_MANAGER_PITCHYAW, FRAME_MISSION,
                          [round(float(f.pitch[k]), 3), 0.0, NAN, NAN, 0.0, 0.0, 0.0]))
            items.append((IMAGE_START_CAPTURE, FRAME_MISSION, [0.0, 0.0, 1.0, 0.0, NAN, NAN, NAN]))
    items.append((NAV_RETURN_TO_LAUNCH, FRAME_MISSION, [0.0] * 7))
    return items


def _json_param(v):
    v = float(v)
    return None if math.isnan(v) else v


@register_writer("qgc", ".plan")
def write_plan(route, path, firmware: str = "px4", speed: float = 5.0, **_ignored) -> list[Path]:
    f = geo_flight(route)
    items = []
    for n, (command, frame, params) in enumerate(mission_items(route), start=1):
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
        "geoFence": {"version": 2, "circles": [], "polygons": []},
        "rallyPoints": {"version": 2, "points": []},
    }
    return [write_atomic(path, json.dumps(plan, indent=1))]


@register_writer("wpl", ".waypoints")
def write_wpl(route, path, **_ignored) -> list[Path]:
    f = geo_flight(route)
    home_alt = f.home[2] if f.home[2] is not None else 0.0
    rows = ["QGC WPL 110", _wpl_row(0, 1, FRAME_GLOBAL, NAV_WAYPOINT, [0, 0, 0, 0, f.home[1], f.home[0], home_alt])]
    for n, (command, frame, params) in enumerate(mission_items(route), start=1):
        rows.append(_wpl_row(n, 0, frame, command, params))
    return [write_atomic(path, "\n".join(rows) + "\n")]


def _wpl_row(index, current, frame, command, params) -> str:
    # The text format has no "unset": NaN becomes 0, as Mission Planner writes it.
    params = [0.0 if math.isnan(float(p)) else float(p) for p in params]
    values = [f"{p:.8f}" if k in (4, 5) else f"{p:.6f}" for k, p in enumerate(params)]
    return "\t".join([str(index), str(current), str(frame), str(command), *values, "1"])
