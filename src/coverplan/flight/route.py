"""Route: the flight as the route file (docs/route-format.md) describes it, with save / load / validate."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from coverplan.equipment.camera import Camera
from coverplan.errors import ParameterError, RouteFormatError
from coverplan.files import absolute_to, read_json, relative_to, write_atomic
from coverplan.flight.corners import corner_offsets, turn_angles
from coverplan.flight.route_file import route_from_dict, route_to_dict
from coverplan.geometry.orientation import (
    angle_between_deg,
    view_direction,
)

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

    def to_dict(self) -> dict:
        return route_to_dict(self)

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
        return route_from_dict(cls, data, path)

    def orientation_errors_deg(self) -> np.ndarray:
        """Angle between each waypoint's view_dir and the one its heading and pitch give.

        Returns
        -------
        (n,) float
            Degrees.
        """
        return angle_between_deg(self.view_dir, view_direction(self.heading_deg, self.pitch_deg))
