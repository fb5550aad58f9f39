"""Route: the flight as the route file (docs/route-format.md) describes it, with save / load / validate."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from coverplan.equipment.camera import Camera
from coverplan.errors import ParameterError, RouteFormatError
from coverplan.files import absolute_to, read_json, relative_to, write_atomic
from coverplan.flight.corners import corner_offsets, turn_angles
from coverplan.geometry.orientation import (
    angle_between_deg,
    heading_pitch,
    view_direction,
)

FORMAT = "coverplan-route"
VERSION = 1
LEGS = ("initial", "coverage", "final")
DEFAULT_PARAMS = {"min_views": 2, "min_triangulation_deg": 5.0, "max_incidence_deg": 70.0}


def polyline_length(points) -> float:
    """Length of the polyline through ``points`` (n x 3).

    Parameters
    ----------
    points : (n, 3) float
        The polyline.

    Returns
    -------
    float
        Metres.
    """
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) if len(p) > 1 else 0.0


def coverage_length(points, shot) -> float:
    """Length from the first shot to the last (the thesis's tables count only this).

    Parameters
    ----------
    points : (n, 3) float
        Waypoints.
    shot : (n,) bool
        Which take a photo.

    Returns
    -------
    float
        Metres.
    """
    rows = np.flatnonzero(shot)
    return polyline_length(np.asarray(points)[rows[0]:rows[-1] + 1]) if len(rows) else 0.0


STRAIGHT_DEG = 0.5  # a waypoint where the path turns less is not a corner

@dataclass
class Route:
    """Waypoints (local metres), the camera and parameters, and what the plan left uncovered.

    What ``plan`` returns and the route file holds (docs/route-format.md).

    Parameters
    ----------
    positions : (n, 3) float
        Waypoints in the local frame (m), from the take-off point back to it.
    shot : (n,) bool
        Whether a photo is taken at each waypoint.
    heading_deg : (n,) float
        Camera heading, degrees clockwise from the local +y axis (grid north).
    pitch_deg : (n,) float
        Gimbal pitch in degrees: 0 level, -90 straight down.
    leg : list of str
        "initial", "coverage" or "final" per waypoint.
    camera : Camera
    params : dict
        The settings it was planned with (``gsd_m``, ``security_m``, ...) and the scene's record.
    view_dir : (n, 3) float, optional
        Unit view directions; derived from heading and pitch when None.
    frame : dict
        Where the local frame sits on Earth: ``crs``, ``origin``, ``geodetic_origin``.
    uncovered : list of dict
        Surface the plan could not cover, with the reason and the area (m2).
    metrics : dict
        The planner's figures and the evaluation.
    extra : dict
        Notes and other planner output.
    flight : (n,) int, optional
        The battery flight (1, 2, ...) of each waypoint; None: one flight.
    ground_z : (n,) float, optional
        The terrain's height under each waypoint (planned over terrain).
    pass_speed : (n,) float, optional
        Speed (m/s) where the drone flies through a waypoint, 0 at stops.
    turn_damping : (n,) float, optional
        Metres before a waypoint flown through at which its turn starts.

    Examples
    --------
    >>> import coverplan
    >>> scene = coverplan.load_scene("meshes/square_prism.obj")
    >>> route = coverplan.plan(scene, coverplan.get_camera("phantom4pro"), gsd=0.004, security=3.0)
    >>> import tempfile
    >>> path = route.save(Path(tempfile.mkdtemp()) / "route.json")
    >>> again = coverplan.Route.load(path)
    >>> int(again.shot.sum()) == int(route.shot.sum()), bool((again.above_ground() >= 3.0 - 1e-6).all())
    (True, True)
    """

    positions: np.ndarray
    shot: np.ndarray
    heading_deg: np.ndarray
    pitch_deg: np.ndarray
    leg: list[str]
    camera: Camera
    params: dict
    view_dir: np.ndarray | None = None
    frame: dict = field(default_factory=lambda: {"crs": None, "origin": [0.0, 0.0, 0.0]})
    uncovered: list[dict] = field(default_factory=list)
    metrics: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)
    flight: np.ndarray | None = None
    ground_z: np.ndarray | None = None
    pass_speed: np.ndarray | None = None
    turn_damping: np.ndarray | None = None

    def __post_init__(self):
        self.positions = np.asarray(self.positions, dtype=float).reshape(-1, 3)
        self.shot = np.asarray(self.shot, dtype=bool)
        self.heading_deg = np.mod(np.asarray(self.heading_deg, dtype=float), 360.0)
        self.pitch_deg = np.asarray(self.pitch_deg, dtype=float)
        if self.view_dir is None:
            self.view_dir = view_direction(self.heading_deg, self.pitch_deg)
        self.view_dir = np.asarray(self.view_dir, dtype=float).reshape(-1, 3)
        self.leg = list(self.leg)
        self.flight = np.ones(len(self.positions), dtype=int) if self.flight is None else \
            np.asarray(self.flight, dtype=int).reshape(-1)
        if self.ground_z is not None:
            self.ground_z = np.asarray(self.ground_z, dtype=float).reshape(-1)
        if (self.pass_speed is None) != (self.turn_damping is None):
            raise ParameterError("a route flown through needs both pass speeds and turn damping distances")
        if self.pass_speed is not None:
            self.pass_speed = np.asarray(self.pass_speed, dtype=float).reshape(-1)
            self.turn_damping = np.asarray(self.turn_damping, dtype=float).reshape(-1)

    @property
    def flies_through(self) -> bool:
        """True when some waypoint is flown through rather than stopped at."""
        return self.pass_speed is not None and bool((self.pass_speed > 0).any())

    def passing(self) -> np.ndarray:
        """(n,) bool: waypoints flown through without stopping.

        Returns
        -------
        (n,) bool
            True where ``pass_speed`` is above 0.
        """
        return np.zeros(len(self), dtype=bool) if self.pass_speed is None else self.pass_speed > 0

    def flown_positions(self) -> np.ndarray:
        """(n, 3) where the drone is as it passes each waypoint: the waypoint itself at a stop,
        off it on the inside of the turn where it flies through (corners.py).

        Returns
        -------
        (n, 3) float
            Metres, local frame.
        """
        if self.turn_damping is None:
            return self.positions.copy()
        return self.positions + corner_offsets(self.positions, np.where(self.passing(), self.turn_damping, 0.0))

    def straight_points(self) -> np.ndarray:
        """(n,) bool: waypoints without a photo inside a flight where the path runs straight on
        (turns under 0.5 deg), such as the turn points between photos (flight/turning.py). A
        drone that stops at every waypoint need not stop there.

        Returns
        -------
        (n,) bool
            The straight transit points.
        """
        out = np.zeros(len(self), dtype=bool)
        for rows in self.flight_rows():
            if len(rows) > 2:
                inner = rows[1:-1]
                out[inner] = ~self.shot[inner] & (turn_angles(self.positions[rows])[1:-1] < STRAIGHT_DEG)
        return out

    def __len__(self) -> int:
        return len(self.positions)

    @property
    def shots(self) -> np.ndarray:
        """(k,) int: the rows of the waypoints that take a photo."""
        return np.flatnonzero(self.shot)

    @property
    def path_length(self) -> float:
        """The length of the whole path through every waypoint, metres."""
        return polyline_length(self.positions)

    @property
    def coverage_length(self) -> float:
        """Length from the first shot to the last (the thesis's tables count only this)."""
        return coverage_length(self.positions, self.shot)

    @property
    def n_flights(self) -> int:
        """How many battery flights the route has."""
        return int(self.flight.max()) if len(self.flight) else 0

    @property
    def takeoff_z(self) -> float:
        """Height of the ground the drone takes off from (under the first waypoint): the
        reference of heights "relative to take-off"."""
        if self.ground_z is not None:
            return float(self.ground_z[0])
        return float(self.params.get("ground_z_m", self.positions[:, 2].min()))

    def above_ground(self) -> np.ndarray:
        """Each waypoint's height above the ground under it (the flat ground without terrain).

        Returns
        -------
        (n,) float
            Metres above the terrain under each waypoint, or above the take-off ground.
        """
        return self.positions[:, 2] - (self.ground_z if self.ground_z is not None else self.takeoff_z)

    def flight_rows(self) -> list[np.ndarray]:
        """Waypoint rows of each battery flight, in order (each from the start point back to it).

        Returns
        -------
        list of (m,) int
            One array of rows per flight.
        """
        return [np.flatnonzero(self.flight == k) for k in range(1, self.n_flights + 1)]

    def flight_route(self, k: int) -> "Route":
        """Flight ``k`` alone, as a route of its own.

        Parameters
        ----------
        k : int
            The battery flight, 1-based.

        Returns
        -------
        Route
        """
        rows = np.flatnonzero(self.flight == k)
        return Route(self.positions[rows], self.shot[rows], self.heading_deg[rows], self.pitch_deg[rows],
                     [self.leg[r] for r in rows], self.camera, dict(self.params), view_dir=self.view_dir[rows],
                     frame=self.frame, metrics={}, extra=dict(self.extra),
                     ground_z=None if self.ground_z is None else self.ground_z[rows],
                     pass_speed=None if self.pass_speed is None else self.pass_speed[rows],
                     turn_damping=None if self.turn_damping is None else self.turn_damping[rows])

    def with_existing_photos(self) -> "Route":
        """This route with the photos it was planned around (``params.existing_photos``) as a
        battery flight of their own after its flights: what SfM gets when the old and the new
        photos are reconstructed together. The route itself when it has none.

        Returns
        -------
        Route
            A new route, or this one.
        """
        taken = self.params.get("existing_photos") or {}
        if not taken.get("positions"):
            return self
        p = np.asarray(taken["positions"], dtype=float).reshape(-1, 3)
        k = len(p)
        params = {key: v for key, v in self.params.items() if key != "existing_photos"}
        zeros = np.zeros(k)
        return Route(np.vstack([self.positions, p]), np.concatenate([self.shot, np.ones(k, dtype=bool)]),
                     np.concatenate([self.heading_deg, np.asarray(taken["heading_deg"], dtype=float)]),
                     np.concatenate([self.pitch_deg, np.asarray(taken["pitch_deg"], dtype=float)]),
                     self.leg + ["coverage"] * k, self.camera, params, frame=self.frame, uncovered=self.uncovered,
                     metrics={}, extra=dict(self.extra),
                     flight=np.concatenate([self.flight, np.full(k, self.n_flights + 1)]),
                     ground_z=None if self.ground_z is None else np.concatenate([self.ground_z,
                                                                                 np.full(k, self.ground_z[0])]),
                     pass_speed=None if self.pass_speed is None else np.concatenate([self.pass_speed, zeros]),
                     turn_damping=None if self.turn_damping is None else np.concatenate([self.turn_damping, zeros]))

    def flight_minutes(self, speed: float, shot_seconds: float) -> float:
        """The simple estimate: the path at ``speed`` m/s plus ``shot_seconds`` per photo.

        Parameters
        ----------
        speed : float
            m/s.
        shot_seconds : float
            Seconds per photo.

        Returns
        -------
        float
            Minutes.
        """
        return (self.path_length / speed + int(self.shot.sum()) * shot_seconds) / 60.0

    @property
    def gsd(self) -> float:
        """The ground sampling distance asked, metres per pixel."""
        return float(self.params["gsd_m"])

    @property
    def security(self) -> float:
        """The security distance, metres."""
        return float(self.params["security_m"])

    @property
    def d_opt(self) -> float:
        """The camera distance of the GSD asked, metres."""
        return self.camera.optimal_distance(self.gsd)

    def param(self, name):
        """A setting the route was planned with, or its default when the file does not record it.

        Parameters
        ----------
        name : str
            A key of ``params``.

        Returns
        -------
        object
            The value.
        """
        return self.params.get(name, DEFAULT_PARAMS.get(name))

    # -- file format -----------------------------------------------------------------
    def to_dict(self) -> dict:
        waypoints = []
        several = self.n_flights > 1
        for k in range(len(self)):
            waypoints.append({
                "position": _round(self.positions[k], 4),
                "shot": bool(self.shot[k]),
                "view_dir": _round(self.view_dir[k], 6),
                "heading_deg": round(float(self.heading_deg[k]), 4),
                "gimbal_pitch_deg": round(float(self.pitch_deg[k]), 4),
                "leg": self.leg[k],
                **({"flight": int(self.flight[k])} if several else {}),
                **({"ground_z": round(float(self.ground_z[k]), 4)} if self.ground_z is not None else {}),
                **({"pass_speed_mps": math.floor(float(self.pass_speed[k]) * 1e4) / 1e4,
                    "turn_damping_m": round(float(self.turn_damping[k]), 4)} if self.pass_speed is not None else {}),
            })
        d = {
            "format": FORMAT, "version": VERSION, "units": "m",
            "frame": {"crs": self.frame.get("crs"), "origin": [float(v) for v in self.frame.get("origin", [0, 0, 0])],
                      **_jsonable({k: v for k, v in self.frame.items() if k not in ("crs", "origin")})},
            "camera": self.camera.to_dict(),
            "params": _jsonable(self.params),
            "waypoints": waypoints,
            "uncovered": _jsonable(self.uncovered),
            "metrics": _jsonable(self.metrics),
        }
        if self.extra:
            d["planner"] = _jsonable(self.extra)
        return d

    def save(self, path, force: bool = True) -> Path:
        """Write the route file atomically (temporary file, then rename).

        Parameters
        ----------
        path : path
            The route file (.json); the scene's files are recorded relative to it.
        force : bool
            Overwrite an existing file.

        Returns
        -------
        Path
            The file written.
        """
        path = Path(path)
        if path.exists() and not force:
            raise ParameterError(f"{path} exists; pass --force to overwrite it")
        data = self.to_dict()
        if data["params"].get("scene"):  # a project folder moves as a whole: its files relative to the route
            data["params"]["scene"] = relative_to(data["params"]["scene"], path.resolve().parent)
        return write_atomic(path, json.dumps(data, indent=1, allow_nan=False))

    @classmethod
    def load(cls, path) -> "Route":
        """Read a route file.

        Parameters
        ----------
        path : path
            A file written by ``Route.save`` (or ``coverplan plan``).

        Returns
        -------
        Route
            With the scene's recorded paths made absolute again.

        Raises
        ------
        RouteFormatError
            A missing file, or one that does not follow the route format.
        """
        path = Path(path)
        if not path.exists():
            raise RouteFormatError(path, "no such file")
        route = cls.from_dict(read_json(path, RouteFormatError), path)
        if isinstance(route.params.get("scene"), dict):  # its files as the route file names them
            route.params["scene"] = absolute_to(route.params["scene"], path.resolve().parent)
        return route

    @classmethod
    def from_dict(cls, data, path="route") -> "Route":
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
        return cls(np.array(pos), np.array(shot), np.array(head), np.array(pitch), leg, camera, dict(params),
                   view_dir=vdir, frame=frame, uncovered=uncovered, metrics=data.get("metrics") or {},
                   extra=data.get("planner") or {}, flight=np.array(flight),
                   ground_z=np.array(ground) if ground else None,
                   pass_speed=np.array([v for v, _ in passes]) if passes else None,
                   turn_damping=np.array([d for _, d in passes]) if passes else None)

    def orientation_errors_deg(self) -> np.ndarray:
        """Angle between each waypoint's view_dir and the one its heading and pitch give.

        Returns
        -------
        (n,) float
            Degrees.
        """
        return angle_between_deg(self.view_dir, view_direction(self.heading_deg, self.pitch_deg))


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
