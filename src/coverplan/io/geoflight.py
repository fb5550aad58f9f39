"""A route as exporters need it: WGS84 positions, heights above take-off and sea level, true headings."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pyproj import Geod

from coverplan.geometry import geo
from coverplan.geometry.geo import grid_convergence

_GEOD = Geod(ellps="WGS84")


@dataclass
class GeoFlight:
    """Waypoints on Earth. ``alt_rel``: metres above the take-off point's ground;
    ``alt_abs``: above sea level when the route's frame knows its height datum, else None.

    Parameters
    ----------
    lon, lat : (n,) float
        WGS 84 degrees.
    alt_rel : (n,) float
        Metres above the take-off point's ground.
    alt_abs : (n,) float or None
        Metres above sea level.
    heading_true : (n,) float
        Degrees clockwise from true north.
    pitch : (n,) float
        Gimbal pitch, degrees.
    shot : (n,) bool
        Which waypoints take a photo.
    leg : list of str
        Each waypoint's leg (initial, coverage, return ...).
    home : (float, float, float or None)
        Take-off latitude, longitude and height above sea level.
    """

    lon: np.ndarray
    lat: np.ndarray
    alt_rel: np.ndarray
    alt_abs: np.ndarray | None
    heading_true: np.ndarray  # degrees clockwise from true north
    pitch: np.ndarray
    shot: np.ndarray
    leg: list
    home: tuple[float, float, float | None]  # lon, lat, ground height above sea level (None if unknown)

    def __len__(self) -> int:
        return len(self.lon)


def heights_are_absolute(frame: dict) -> bool:
    """Whether a route's heights can be given above sea level (its frame knows its datum).

    Parameters
    ----------
    frame : dict
        The route file's ``frame``.

    Returns
    -------
    bool
        True with a geodetic origin or a vertical CRS.
    """
    return bool(frame.get("geodetic_origin") or frame.get("vertical_crs"))


def geo_flight(route) -> GeoFlight:
    """The route's waypoints in WGS84 (raises ParameterError when it has no georeference).

    Parameters
    ----------
    route : Route
        The route (one battery flight).

    Returns
    -------
    GeoFlight
        The waypoints on Earth.
    """
    frame = route.frame
    lon, lat, h = geo.to_lonlat(frame, route.positions)
    ground = route.takeoff_z
    alt_rel = route.positions[:, 2] - ground
    absolute = heights_are_absolute(frame)
    home_lon, home_lat, home_h = geo.to_lonlat(frame, [[route.positions[0, 0], route.positions[0, 1], ground]])
    heading = np.mod(route.heading_deg + grid_convergence(frame, route.positions), 360.0)
    return GeoFlight(np.asarray(lon), np.asarray(lat), alt_rel, np.asarray(h) if absolute else None, heading,
                     route.pitch_deg.copy(), route.shot.copy(), list(route.leg),
                     (float(home_lon[0]), float(home_lat[0]), float(home_h[0]) if absolute else None))


@dataclass
class GeoZone:
    """A zone of the route on Earth: its rings (exterior first, then holes) per polygon, as
    (n, 2) longitude, latitude without the closing point.

    Parameters
    ----------
    name : str
        The zone's name.
    kind : {"keep_out", "keep_in"}
        Its kind.
    polygons : list of list of (n, 2) float
        Rings per polygon.
    floor_m, ceiling_m : float or None
        Local z as the route records it, metres; None when open.
    """

    name: str
    kind: str  # "keep-out" or "keep-in"
    polygons: list  # per polygon: list of (n, 2) float rings
    floor_m: float | None  # local z, as the route records it
    ceiling_m: float | None


def geo_zones(route) -> list[GeoZone]:
    """The route's keep-out and keep-in zones in WGS84 (none without a georeference).

    Parameters
    ----------
    route : Route
        The route.

    Returns
    -------
    list of GeoZone
        The zones.
    """
    zones = route.params.get("zones") or []
    if not zones or not geo.has_georeference(route.frame):
        return []
    out = []
    for z in zones:
        polygons = []
        for rings in z["polygons"]:
            mine = []
            for ring in rings:
                ring = np.asarray(ring, dtype=float)[:-1]  # shapely closes rings; exporters close their own
                lon, lat, _h = geo.to_lonlat(route.frame, np.column_stack([ring, np.zeros(len(ring))]))
                mine.append(np.column_stack([lon, lat]))
            polygons.append(mine)
        out.append(GeoZone(z["name"], z["kind"], polygons, z.get("floor_m"), z.get("ceiling_m")))
    return out
