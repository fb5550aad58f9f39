"""The route file: a Route as JSON and back, every field checked on the way in (docs/route-format.md)."""

from __future__ import annotations

import math

import numpy as np

from coverplan.equipment.camera import Camera
from coverplan.errors import ParameterError, RouteFormatError
from coverplan.geometry.orientation import heading_pitch, view_direction

FORMAT = "coverplan-route"
VERSION = 1
LEGS = ("initial", "coverage", "final")


def route_to_dict(route) -> dict:
    """The route file's JSON object of ``route`` (docs/route-format.md).

    Parameters
    ----------
    route : Route
        The route.

    Returns
    -------
    dict
        JSON-ready values.
    """
    waypoints = []
    several = route.n_flights > 1
    for k in range(len(route)):
        waypoints.append({
            "position": _round(route.positions[k], 4),
            "shot": bool(route.shot[k]),
            "view_dir": _round(route.view_dir[k], 6),
            "heading_deg": round(float(route.heading_deg[k]), 4),
            "gimbal_pitch_deg": round(float(route.pitch_deg[k]), 4),
            "leg": route.leg[k],
            **({"flight": int(route.flight[k])} if several else {}),
            **({"ground_z": round(float(route.ground_z[k]), 4)} if route.ground_z is not None else {}),
            **({"pass_speed_mps": math.floor(float(route.pass_speed[k]) * 1e4) / 1e4,
                "turn_damping_m": round(float(route.turn_damping[k]), 4)} if route.pass_speed is not None else {}),
        })
    d = {
        "format": FORMAT, "version": VERSION, "units": "m",
        "frame": {"crs": route.frame.get("crs"), "origin": [float(v) for v in route.frame.get("origin", [0, 0, 0])],
                  **_jsonable({k: v for k, v in route.frame.items() if k not in ("crs", "origin")})},
        "camera": route.camera.to_dict(),
        "params": _jsonable(route.params),
        "waypoints": waypoints,
        "uncovered": _jsonable(route.uncovered),
        "metrics": _jsonable(route.metrics),
    }
    if route.extra:
        d["planner"] = _jsonable(route.extra)
    return d


def route_from_dict(route_class, data, path="route"):
    """A route of class ``route_class`` from the route file's JSON object, every field checked.

    Parameters
    ----------
    route_class : type
        Route, or a subclass.
    data : object
        The decoded JSON.
    path : str or Path
        The file, for errors.

    Returns
    -------
    Route
        The route.

    Raises
    ------
    RouteFormatError
        Naming the field that does not follow the format.
    """
    if not isinstance(data, dict):
        raise RouteFormatError(path, "is not a route: expected a JSON object")
    if data.get("format") != FORMAT:
        raise RouteFormatError(path, f"is not a route: 'format' is {data.get('format')!r}, expected {FORMAT!r}")
    if data.get("version") != VERSION:
        raise RouteFormatError(path, f"route version {data.get('version')!r} is not supported (expected {VERSION})")
    if data.get("units", "m") != "m":
        raise RouteFormatError(path, f"route units must be 'm', got {data.get('units')!r}")
    try:
        camera = Camera.from_dict(_require(data, "camera", dict, path))
    except ParameterError as exc:
        raise RouteFormatError(path, str(exc)) from None
    params = _require(data, "params", dict, path)
    for key in ("gsd_m", "security_m"):
        if not _positive(params.get(key)):
            raise RouteFormatError(path, f"params.{key} must be a positive number, got {params.get(key)!r}")
    waypoints = _require(data, "waypoints", list, path)
    if not waypoints:
        raise RouteFormatError(path, "has no waypoints")
    pos, shot, vdir, head, pitch, leg, flight, ground, passes = [], [], [], [], [], [], [], [], []
    for k, wp in enumerate(waypoints):
        if not isinstance(wp, dict):
            raise RouteFormatError(path, f"waypoint {k} is not an object")
        pos.append(_vector(wp.get("position"), f"waypoint {k} position", path))
        shot.append(bool(wp.get("shot", False)))
        h, p = wp.get("heading_deg"), wp.get("gimbal_pitch_deg")
        vd = wp.get("view_dir")
        if vd is None and (h is None or p is None):
            if shot[-1]:
                raise RouteFormatError(path, f"waypoint {k} is a photo but has neither view_dir nor "
                                             "heading_deg/gimbal_pitch_deg")
            h, p = 0.0, 0.0  # a waypoint without a photo needs no orientation
        if h is not None and not _finite(h) or p is not None and not _finite(p):
            raise RouteFormatError(path, f"waypoint {k} heading/pitch must be finite numbers")
        vd = _vector(vd, f"waypoint {k} view_dir", path) if vd is not None else None
        if vd is not None and np.linalg.norm(vd) == 0:
            raise RouteFormatError(path, f"waypoint {k} view_dir is zero")
        if h is None or p is None:
            h, p = (float(a) for a in heading_pitch(vd))
        vdir.append(vd if vd is not None else view_direction(h, p))
        head.append(float(h))
        pitch.append(float(p))
        lg = wp.get("leg", "coverage")
        if lg not in LEGS:
            raise RouteFormatError(path, f"waypoint {k} leg {lg!r} is not one of {', '.join(LEGS)}")
        leg.append(lg)
        fl = wp.get("flight", 1)
        whole = isinstance(fl, int) and not isinstance(fl, bool) and fl >= 1
        if not whole or (flight and fl not in (flight[-1], flight[-1] + 1)):
            raise RouteFormatError(path, f"waypoint {k} flight {fl!r} must be a whole number >= 1 that stays or "
                                         "goes up by one from the waypoint before")
        flight.append(fl)
        g = wp.get("ground_z")
        if (g is not None and not _finite(g)) or (k > 0 and (g is None) != (len(ground) == 0)):
            raise RouteFormatError(path, f"waypoint {k} ground_z must be a finite number, given for every "
                                         "waypoint or for none")
        if g is not None:
            ground.append(float(g))
        v, d = wp.get("pass_speed_mps"), wp.get("turn_damping_m")
        given = v is not None or d is not None
        if given and not (_finite(v) and _finite(d) and v >= 0 and d >= 0) \
                or (k > 0 and given != bool(passes)):
            raise RouteFormatError(path, f"waypoint {k} pass_speed_mps and turn_damping_m must be numbers >= 0, "
                                         "given together for every waypoint or for none")
        if given:
            passes.append((float(v), float(d)))
    if flight[0] != 1:
        raise RouteFormatError(path, "the first waypoint must be in flight 1")
    frame = data.get("frame") or {"crs": None, "origin": [0.0, 0.0, 0.0]}
    if not isinstance(frame, dict):
        raise RouteFormatError(path, "'frame' must be an object")
    frame = {"crs": frame.get("crs"),
             "origin": list(_vector(frame.get("origin", [0, 0, 0]), "frame.origin", path)),
             **{k: v for k, v in frame.items() if k not in ("crs", "origin")}}
    uncovered = data.get("uncovered", [])
    if not isinstance(uncovered, list):
        raise RouteFormatError(path, "'uncovered' must be a list")
    vdir = np.array(vdir, dtype=float)
    vdir /= np.linalg.norm(vdir, axis=1, keepdims=True)
    return route_class(np.array(pos), np.array(shot), np.array(head), np.array(pitch), leg, camera, dict(params),
               view_dir=vdir, frame=frame, uncovered=uncovered, metrics=data.get("metrics") or {},
               extra=data.get("planner") or {}, flight=np.array(flight),
               ground_z=np.array(ground) if ground else None,
               pass_speed=np.array([v for v, _ in passes]) if passes else None,
               turn_damping=np.array([d for _, d in passes]) if passes else None)


def _require(data, key, kind, path):
    if key not in data:
        raise RouteFormatError(path, f"is missing '{key}'")
    if not isinstance(data[key], kind):
        raise RouteFormatError(path, f"'{key}' must be a {'list' if kind is list else 'object'}")
    return data[key]


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _positive(v) -> bool:
    return _finite(v) and v > 0


def _vector(value, what, path) -> np.ndarray:
    if not isinstance(value, (list, tuple)) or len(value) != 3 or not all(_finite(v) for v in value):
        raise RouteFormatError(path, f"{what} must be three finite numbers, got {value!r}")
    return np.array(value, dtype=float)


def _round(v, digits):
    return [round(float(x), digits) for x in v]


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj
