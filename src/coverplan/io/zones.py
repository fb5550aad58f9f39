"""Zone files: GeoJSON (or GeoPackage / Shapefile) polygons as keep-out or keep-in prisms.

Polygons are in WGS84 longitude/latitude (RFC 7946) or in the projected CRS a legacy "crs"
member names (the models' own, or any other pyproj knows). Per feature, optional properties:

- ``name``: how reports and errors name the zone (default: the feature's id or number);
- ``floor``, ``ceiling``: the prism's bottom and top, m (default: from the ground, no top);
- ``heights``: ``"ground"`` (default; above the ground) or ``"absolute"`` (in the models'
  height system).

Over a terrain, heights above the ground become one absolute floor and ceiling per zone,
chosen to never let the flight breach it: a keep-out zone reaches from its lowest ground plus
its floor to its highest ground plus its ceiling, a keep-in zone the other way round.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import shapely
from pyproj import CRS, Transformer

from coverplan.errors import InputFileError, ParameterError
from coverplan.geometry.geo import WGS84, from_lonlat, has_georeference
from coverplan.io.footprints import read_features
from coverplan.io.registry import ZONE_READERS, register_zone_reader
from coverplan.world.zones import KEEP_IN, KEEP_OUT, Zone, Zones

EXTENSIONS = ("geojson", "json", "gpkg", "shp")
HEIGHTS = ("ground", "absolute")


@register_zone_reader(*EXTENSIONS)
def read_zone_file(path, kind: str, scene) -> list[Zone]:
    """The zones of one file, in ``scene``'s local frame.

    Parameters
    ----------
    path : path-like
        GeoJSON, GeoPackage or Shapefile of polygons.
    kind : {"keep-out", "keep-in"}
    scene : Scene
        Gives the local frame (CRS and origin, or geodetic origin) and the ground.

    Returns
    -------
    list of Zone
    """
    path = Path(path)
    if not path.is_file():
        raise InputFileError(path, "no such file" if not path.exists() else "is a directory, not a zone file")
    geometries, ids, props, crs = read_features(path)
    if not geometries:
        raise InputFileError(path, f"holds no {kind} zones")
    to_local = _plan_transform(path, crs, scene)
    zones = []
    for k, (geom, fid, attrs) in enumerate(zip(geometries, ids, props)):
        name = str(attrs.get("name") or fid)
        if geom is None or geom.geom_type not in ("Polygon", "MultiPolygon"):
            what = "no geometry" if geom is None else f"a {geom.geom_type}"
            raise InputFileError(path, f"feature {name} is {what}, not a polygon: {kind} zones are polygons")
        if not geom.is_valid:
            raise InputFileError(path, f"feature {name} is not a valid polygon ({shapely.is_valid_reason(geom)})")
        polygon = shapely.transform(geom, to_local)
        if polygon.area <= 0:
            raise InputFileError(path, f"feature {name} has no area")
        floor, ceiling = _heights(path, name, attrs, kind, polygon, scene)
        zones.append(Zone(name, kind, polygon, floor, ceiling))
    return zones


def read_zones(keep_out=(), keep_in=(), scene=None) -> Zones:
    """Every zone of the ``keep_out`` and ``keep_in`` files (paths), in ``scene``'s frame.

    Parameters
    ----------
    keep_out, keep_in : sequence of str or Path
        Zone files.
    scene : Scene, optional
        Gives the frame; the files' own coordinates when None.

    Returns
    -------
    Zones
        Every zone read.
    """
    zones = []
    for kind, paths in ((KEEP_OUT, keep_out), (KEEP_IN, keep_in)):
        for path in ([paths] if isinstance(paths, (str, Path)) else paths or ()):
            path = Path(path)
            reader = ZONE_READERS.get(path.suffix.lower().lstrip("."))
            if reader is None:
                raise InputFileError(path, f"is not a zone file; give polygons as "
                                           f"{', '.join('.' + e for e in sorted(ZONE_READERS))}")
            zones += reader(path, kind, scene)
    return Zones(tuple(zones))


def _plan_transform(path: Path, crs, scene):
    """A function mapping the file's (n, 2) plan coordinates to the scene's local x, y."""
    frame = scene.frame
    source = CRS.from_user_input(crs) if crs else CRS.from_epsg(4326)
    origin = np.asarray(frame.get("origin") or [0.0, 0.0, 0.0], dtype=float)
    if frame.get("crs") and CRS.from_user_input(frame["crs"]) == source:
        unit = float(frame.get("crs_unit_m", 1.0))
        return lambda xy: xy * unit - origin[:2]
    if not has_georeference(frame):
        where = "WGS84 longitude/latitude" if not crs else str(crs)
        raise ParameterError(f"{path.name} is in {where}, but the models carry no georeference: give --crs EPSG:XXXX "
                             "(the models' CRS) or --geo-origin LAT LON H")
    to_wgs84 = None if source == CRS.from_user_input(WGS84) else Transformer.from_crs(source, WGS84, always_xy=True)

    def convert(xy):
        lon, lat = (xy[:, 0], xy[:, 1]) if to_wgs84 is None else to_wgs84.transform(xy[:, 0], xy[:, 1])
        return from_lonlat(frame, lon, lat, np.zeros(len(xy)))[:, :2]
    return convert


def _heights(path: Path, name: str, attrs: dict, kind: str, polygon, scene) -> tuple[float, float]:
    """The zone's floor and ceiling as local z."""
    def number(key):
        value = attrs.get(key)
        if value is None:
            return None
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise InputFileError(path, f"zone {name}: {key} is {value!r}, not a number of metres") from None
        if not np.isfinite(value):
            raise InputFileError(path, f"zone {name}: {key} must be a finite number of metres, got {value!r}")
        return value

    floor, ceiling = number("floor"), number("ceiling")
    heights = str(attrs.get("heights") or "ground")
    if heights not in HEIGHTS:
        raise InputFileError(path, f"zone {name}: heights must be one of {', '.join(HEIGHTS)}, got {heights!r}")
    if floor is not None and ceiling is not None and not floor < ceiling:
        raise InputFileError(path, f"zone {name}: floor {floor:g} m is not below its ceiling {ceiling:g} m")
    if heights == "absolute":
        dz = float(scene.origin[2])
        return (-np.inf if floor is None else floor - dz), (np.inf if ceiling is None else ceiling - dz)
    if scene.terrain is not None:
        x0, y0, x1, y1 = polygon.bounds
        low, high = scene.terrain.lowest_in((x0, y0), (x1, y1)), scene.terrain.highest_in((x0, y0), (x1, y1))
    else:
        low = high = float(scene.ground_z)
    # The prism that never lets the flight breach the zone over uneven ground.
    under, over = (low, high) if kind == KEEP_OUT else (high, low)
    return (-np.inf if floor is None else under + floor), (np.inf if ceiling is None else over + ceiling)
