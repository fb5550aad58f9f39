"""Missions written by flight apps (QGroundControl, Mission Planner, Litchi, ...) as routes,
so that the evaluator can judge a flight drawn by hand or by another tool.

A mission gives WGS84 positions and heights with a reference: above the take-off point
("takeoff") or above mean sea level ("amsl"). They are placed in the scene's frame: x, y
through the scene's georeference (``geo.from_lonlat``); a height above take-off is added to
the ground under the take-off point (the scene's ground plane, ``Scene.ground_z``); a height
above sea level needs a scene whose heights are above sea level too (a vertical CRS or a
geodetic origin), and is refused otherwise. Headings are true north; they are turned into
the scene's grid north.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from coverplan.errors import InputFileError, ParameterError
from coverplan.flight.route import Route
from coverplan.geometry import geo
from coverplan.geometry.geo import grid_convergence
from coverplan.shots.reconstructability import MatchRule

TAKEOFF, AMSL, GROUND = "takeoff", "amsl", "ground"  # GROUND: above the ground under the waypoint
WGS84_A, WGS84_E2 = 6_378_137.0, 6.694379990141e-3  # semi-major axis (m), first eccentricity squared


def mission_number(v) -> float:
    """A mission file's number (a JSON value or XML text); NaN where it is missing or not one.

    Parameters
    ----------
    v : object
        A JSON value or XML text.

    Returns
    -------
    float
        The number or NaN.
    """
    try:
        return float("nan") if v is None else float(v)
    except (TypeError, ValueError):
        return float("nan")


@dataclass
class Mission:
    """Waypoints as a flight app stores them. NaN heading/pitch: the file does not say.

    Parameters
    ----------
    lat, lon : (n,) float
        WGS 84 degrees.
    alt : (n,) float
        Metres.
    alt_ref : (n,) str
        TAKEOFF, GROUND or AMSL: what each altitude is above.
    heading_true : (n,) float
        Degrees clockwise from true north.
    pitch : (n,) float
        Gimbal pitch, degrees.
    shot : (n,) bool
        Which take a photo.
    source : str
        What the file is.
    home : (float, float), optional
        Latitude and longitude of the take-off point.
    notes : list of str
        What the reader did.
    pass_speed : (n,) float, optional
        m/s where the app flies through a waypoint, else 0.
    turn_damping : (n,) float, optional
        Metres before such a waypoint that its turn starts.
    """

    lat: np.ndarray
    lon: np.ndarray
    alt: np.ndarray
    alt_ref: np.ndarray  # TAKEOFF, GROUND or AMSL per waypoint
    heading_true: np.ndarray
    pitch: np.ndarray
    shot: np.ndarray
    source: str
    home: tuple[float, float] | None = None  # lat, lon of the take-off point
    notes: list[str] = field(default_factory=list)
    pass_speed: np.ndarray | None = None  # m/s where the app flies through a waypoint, else 0
    turn_damping: np.ndarray | None = None  # m before such a waypoint that its turn starts

    def __len__(self) -> int:
        return len(self.lat)


class MissionBuilder:
    """Collects waypoints and photos while a reader walks a mission's items in order.

    Parameters
    ----------
    path : str or Path
        The mission file, for errors.
    source : str
        What the file is.
    """

    def __init__(self, path, source: str):
        self.path, self.source = Path(path), source
        self.rows: list[list] = []  # lat, lon, alt, ref, heading, pitch, shot
        self.passes: dict[int, tuple[float, float]] = {}  # row -> (pass speed, turn damping)
        self.heading = np.nan
        self.pitch = np.nan
        self.notes: list[str] = []

    def waypoint(self, lat, lon, alt, ref: str, heading=np.nan) -> None:
        """Append a waypoint, with the gimbal pitch set so far.

        Parameters
        ----------
        lat, lon : float
            WGS 84 degrees.
        alt : float
            Metres.
        ref : str
            TAKEOFF, GROUND or AMSL.
        heading : float
            Degrees from true north; NaN keeps the last heading set.

        Raises
        ------
        InputFileError
            When a coordinate is missing or the point is not on Earth.
        """
        for name, v in (("latitude", lat), ("longitude", lon), ("altitude", alt)):
            if v is None or not np.isfinite(float(v)):
                raise InputFileError(self.path, f"waypoint {len(self.rows) + 1} has no {name}")
        if not (-90 <= float(lat) <= 90 and -180 <= float(lon) <= 180):
            raise InputFileError(self.path, f"waypoint {len(self.rows) + 1} is not on Earth "
                                            f"(latitude {lat}, longitude {lon})")
        if heading is not None and np.isfinite(float(heading)):
            self.heading = float(heading)
        self.rows.append([float(lat), float(lon), float(alt), ref, self.heading, self.pitch, False])

    def flown_through(self, damping_m: float, speed: float) -> None:
        """The last waypoint is flown through, its turn starting ``damping_m`` before it.

        Parameters
        ----------
        damping_m : float
            Metres.
        speed : float
            m/s.
        """
        if self.rows and np.isfinite(damping_m) and damping_m > 0:
            self.passes[len(self.rows) - 1] = (float(speed) if np.isfinite(speed) and speed > 0 else 1.0,
                                               float(damping_m))

    def distance_photos(self, lat, lon, alt, every: float, since: float) -> float:
        """The photos a distance trigger takes on the leg from the last waypoint to (lat, lon,
        alt): every ``every`` metres of path, ``since`` metres flown since the last one. Returns
        the metres flown since the last photo at the leg's end.

        Parameters
        ----------
        lat, lon : float
            The leg's end, degrees.
        alt : float
            Metres.
        every : float
            Metres between photos.
        since : float
            Metres flown since the last photo.

        Returns
        -------
        float
            Metres.
        """
        lat0, lon0, alt0, ref = self.rows[-1][:4]
        if not (np.isfinite(lat) and np.isfinite(lon)) or not every > 0:
            return since
        dz = (alt - alt0) if np.isfinite(alt) else 0.0
        # metres per degree on the WGS84 ellipsoid at the leg's start: exact to well under a
        # millimetre over a mission's legs
        w = 1.0 - WGS84_E2 * np.sin(np.radians(lat0)) ** 2
        north, east = WGS84_A * (1.0 - WGS84_E2) / w ** 1.5, WGS84_A / np.sqrt(w) * np.cos(np.radians(lat0))
        d = np.array([np.radians(lon - lon0) * east, np.radians(lat - lat0) * north, dz])
        length = float(np.linalg.norm(d))
        s = every - since
        while s < length - 1e-3:  # one that would fall on the next waypoint (within 1 mm) is not taken
            t = s / length
            self.waypoint(lat0 + t * (lat - lat0), lon0 + t * (lon - lon0), alt0 + t * dz, ref)
            self.photo()
            s += every
        return every - (s - length)

    def photo(self) -> None:
        """Take a photo at the last waypoint."""
        if not self.rows:
            raise InputFileError(self.path, "takes a photo before its first waypoint")
        last = self.rows[-1]
        if last[6]:  # a second photo at the same spot becomes a waypoint of its own
            self.rows.append(list(last))
            last = self.rows[-1]
        last[4], last[5], last[6] = self.heading, self.pitch, True

    def build(self, home=None) -> Mission:
        """The mission collected.

        Parameters
        ----------
        home : (float, float), optional
            Latitude and longitude of the take-off point, when the file gives it.

        Returns
        -------
        Mission
            The mission.

        Raises
        ------
        InputFileError
            When the file holds no waypoint.
        """
        if not self.rows:
            raise InputFileError(self.path, "has no waypoints")
        cols = list(zip(*self.rows))
        speed = damping = None
        if self.passes:
            speed, damping = np.zeros(len(self.rows)), np.zeros(len(self.rows))
            for k, (v, d) in self.passes.items():
                speed[k], damping[k] = v, d
        return Mission(np.array(cols[0]), np.array(cols[1]), np.array(cols[2]), np.array(cols[3]),
                       np.array(cols[4], dtype=float), np.array(cols[5], dtype=float), np.array(cols[6], dtype=bool),
                       self.source, home, self.notes, speed, damping)


def mission_to_route(mission: Mission, scene, camera, gsd: float, security: float, params: dict | None = None):
    """The mission as a Route in ``scene``'s frame (see the module docstring for heights).

    Parameters
    ----------
    mission : Mission
        The mission.
    scene : Scene
        Gives the frame and the ground.
    camera : Camera
        The camera flown.
    gsd : float
        Metres per pixel at d_opt.
    security : float
        The security distance, metres.
    params : dict, optional
        More route params.

    Returns
    -------
    Route
        The route.
    """

    frame = scene.frame
    if not geo.has_georeference(frame):
        raise ParameterError(f"the {mission.source} gives latitude/longitude, but the scene has no georeference: "
                             "pass --crs EPSG:XXXX or --geo-origin LAT LON H (as for planning)")
    local = geo.from_lonlat(frame, mission.lon, mission.lat, np.zeros(len(mission)))
    z = np.empty(len(mission))
    above_takeoff = mission.alt_ref == TAKEOFF
    # The drone takes off from the ground under the first waypoint (the terrain's, when known).
    takeoff = float(scene.ground_at(local[:1, :2])[0])
    z[above_takeoff] = takeoff + mission.alt[above_takeoff]
    on_ground = mission.alt_ref == GROUND
    z[on_ground] = scene.ground_at(local[on_ground, :2]) + mission.alt[on_ground]
    above_takeoff |= on_ground  # settled: not above sea level
    if (~above_takeoff).any():
        if not (frame.get("vertical_crs") or frame.get("geodetic_origin")):
            raise ParameterError(f"the {mission.source} gives heights above sea level, but the scene's "
                                 "heights have no datum; pass --geo-origin LAT LON H, or use a city model "
                                 "with a vertical CRS")
        # The height of local z 0: the CRS origin's, or the geodetic origin's own height.
        origin_z = float(frame["geodetic_origin"][2]) if frame.get("geodetic_origin") else \
            float(np.asarray(frame.get("origin") or [0, 0, 0], dtype=float)[2])
        z[~above_takeoff] = mission.alt[~above_takeoff] - origin_z
    positions = np.column_stack([local[:, 0], local[:, 1], z])
    notes = list(mission.notes)
    heading = mission.heading_true - grid_convergence(frame, positions)
    pitch = mission.pitch.copy()
    unset = ~np.isfinite(heading)
    if (unset & mission.shot).any():
        notes.append(f"{int((unset & mission.shot).sum())} photos have no heading in the file: taken facing "
                     "the next waypoint, as autopilots do")
    step = np.diff(positions[:, :2], axis=0, append=positions[-1:, :2])
    travel = np.degrees(np.arctan2(step[:, 0], step[:, 1]))
    heading[unset] = travel[unset]
    if (~np.isfinite(pitch) & mission.shot).any():
        notes.append(f"{int((~np.isfinite(pitch) & mission.shot).sum())} photos have no gimbal pitch in the "
                     "file: taken level (0 deg)")
    pitch[~np.isfinite(pitch)] = 0.0
    shot_rows = np.flatnonzero(mission.shot)
    if len(shot_rows) == 0:
        notes.append("the mission takes no photos")
    first, last = (shot_rows[0], shot_rows[-1]) if len(shot_rows) else (len(mission), -1)
    legs = ["initial" if k < first else "final" if k > last else "coverage" for k in range(len(mission))]
    rule = MatchRule()
    p = {"gsd_m": float(gsd), "security_m": float(security), "min_views": 3, "min_triangulation_deg": 5.0,
         "max_incidence_deg": 70.0, "min_altitude_m": float(security), "ground_z_m": float(scene.ground_z),
         "rule": "sfm", "max_pair_deg": rule.max_pair_deg, "min_overlap": rule.min_overlap,
         "min_neighbours": rule.min_neighbours, **(params or {})}
    route = Route(positions, mission.shot, heading, pitch, legs, camera, p, frame=frame,
                  pass_speed=mission.pass_speed, turn_damping=mission.turn_damping)
    route.extra = {"notes": notes, "source": mission.source}
    return route
