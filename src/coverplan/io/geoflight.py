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
    ``alt_abs``: above sea level when the route's frame knows its height datum, else None."""

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
    return bool(frame.get("geodetic_origin") or frame.get("vertical_crs"))


def geo_flight(route) -> GeoFlight:
    """The route's waypoints in WGS84 (raises ParameterError when it has no georeference)."""
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
    (n, 2) longitude, latitude without the closing point."""

    name: str
    kind: str  # "keep-out" or "keep-in"
    polygons: list  # per polygon: list of (n, 2) float rings
    floor_m: float | None  # local z, as the route records it
    ceiling_m: float | None


def geo_zones(route) -> list[GeoZone]:
    """The route's keep-out and keep-in zones in WGS84 (none without a georeference)."""
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
