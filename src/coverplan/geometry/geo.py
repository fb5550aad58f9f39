"""Local route coordinates <-> WGS84, for exporters.

A route's ``frame`` says where its local metres sit on Earth, one of two ways:

- ``crs`` (e.g. "EPSG:25832") and ``origin``: local + origin are coordinates in that CRS, in
  metres (divided by ``crs_unit_m`` for a CRS counting in feet); heights are in
  ``vertical_crs`` when given (orthometric, above sea level), else unknown;
- ``geodetic_origin`` [lat, lon, h]: local x, y, z are east, north, up of a tangent plane
  (ENU) at that point, h ellipsoidal or above sea level as the user gave it.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from pyproj import CRS, Geod, Transformer
from pyproj.exceptions import CRSError

from coverplan.errors import ParameterError

WGS84 = "EPSG:4326"


def has_georeference(frame: dict) -> bool:
    """Whether a route's frame places it on the Earth (a CRS or a geodetic origin).

    Parameters
    ----------
    frame : dict
        The route file's ``frame``.

    Returns
    -------
    bool
        True with a georeference.
    """
    return bool(frame.get("crs") or frame.get("geodetic_origin"))


@lru_cache(maxsize=16)
def _transformer(src: str, dst: str) -> Transformer:
    return Transformer.from_crs(src, dst, always_xy=True)


def check_crs(text: str) -> str:
    """A CRS string pyproj understands, or a ParameterError naming it.

    Parameters
    ----------
    text : str
        An EPSG code, WKT or PROJ string.

    Returns
    -------
    str
        ``text``.

    Raises
    ------
    ParameterError
        When pyproj does not know it.
    """
    try:
        crs = CRS.from_user_input(text)
    except CRSError:
        raise ParameterError(f"unknown coordinate reference system {text!r} (use e.g. EPSG:25832)") from None
    if crs.is_geographic:
        raise ParameterError(f"{text} is geographic (degrees); mesh coordinates need a projected CRS in metres")
    return text


def to_lonlat(frame: dict, local) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Longitude, latitude (degrees) and height (m, in the frame's height system) of local points.

    Parameters
    ----------
    frame : dict
        The route file's ``frame``.
    local : (n, 3) float
        Points in the local frame, metres.

    Returns
    -------
    lon, lat, h : (n,) float
        Degrees and metres.
    """
    local = np.asarray(local, dtype=float).reshape(-1, 3)
    origin = np.asarray(frame.get("origin") or [0.0, 0.0, 0.0], dtype=float)
    if frame.get("crs"):
        src = local + origin  # metres; the CRS may count in feet
        unit = float(frame.get("crs_unit_m", 1.0))
        lon, lat = _transformer(frame["crs"], WGS84).transform(src[:, 0] / unit, src[:, 1] / unit)
        return np.asarray(lon), np.asarray(lat), src[:, 2]
    if frame.get("geodetic_origin"):
        lat0, lon0, h0 = (float(v) for v in frame["geodetic_origin"])
        ecef = _enu_to_ecef(local, lat0, lon0, h0)
        lon, lat, h = _transformer("EPSG:4978", "EPSG:4979").transform(ecef[:, 0], ecef[:, 1], ecef[:, 2])
        return np.asarray(lon), np.asarray(lat), np.asarray(h)
    raise ParameterError("the route has no georeference (no CRS and no geodetic origin); plan from a "
                         "CityGML/CityJSON file, or pass --crs EPSG:XXXX or --geo-origin LAT LON H")


def from_lonlat(frame: dict, lon, lat, h) -> np.ndarray:
    """Inverse of :func:`to_lonlat`: local coordinates of WGS84 points.

    Parameters
    ----------
    frame : dict
        The route file's ``frame``.
    lon, lat : (n,) float
        WGS 84 degrees.
    h : (n,) float
        Heights in the frame's height system, metres.

    Returns
    -------
    (n, 3) float
        Local coordinates, metres.
    """
    lon, lat, h = (np.asarray(a, dtype=float) for a in (lon, lat, h))
    origin = np.asarray(frame.get("origin") or [0.0, 0.0, 0.0], dtype=float)
    if frame.get("crs"):
        unit = float(frame.get("crs_unit_m", 1.0))
        x, y = _transformer(WGS84, frame["crs"]).transform(lon, lat)
        return np.column_stack([np.asarray(x) * unit, np.asarray(y) * unit, h]) - origin
    lat0, lon0, h0 = (float(v) for v in frame["geodetic_origin"])
    x, y, z = _transformer("EPSG:4979", "EPSG:4978").transform(lon, lat, h)
    return _ecef_to_enu(np.column_stack([x, y, z]), lat0, lon0, h0)


def _rotation(lat0: float, lon0: float) -> np.ndarray:
    """Rows: east, north, up unit vectors in ECEF at (lat0, lon0)."""
    la, lo = np.radians(lat0), np.radians(lon0)
    return np.array([[-np.sin(lo), np.cos(lo), 0.0],
                     [-np.sin(la) * np.cos(lo), -np.sin(la) * np.sin(lo), np.cos(la)],
                     [np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)]])


def _origin_ecef(lat0, lon0, h0) -> np.ndarray:
    return np.array(_transformer("EPSG:4979", "EPSG:4978").transform(lon0, lat0, h0))


def _enu_to_ecef(enu, lat0, lon0, h0) -> np.ndarray:
    return enu @ _rotation(lat0, lon0) + _origin_ecef(lat0, lon0, h0)


def _ecef_to_enu(ecef, lat0, lon0, h0) -> np.ndarray:
    return (ecef - _origin_ecef(lat0, lon0, h0)) @ _rotation(lat0, lon0).T


def checked_transformer(src: str, dst: str) -> Transformer:
    """The most accurate transformation, or a ParameterError naming the PROJ grids it lacks.

    Parameters
    ----------
    src, dst : str
        Source and destination CRS.

    Returns
    -------
    pyproj.Transformer
        The most accurate transformation available.

    Raises
    ------
    ParameterError
        When the best transformation needs PROJ grids that are not installed.
    """
    import warnings

    from pyproj.transformer import TransformerGroup
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        group = TransformerGroup(src, dst, always_xy=True)
    if not group.best_available or not group.transformers:
        grids = sorted({g.short_name for op in group.unavailable_operations for g in op.grids if not g.available})
        raise ParameterError(
            f"heights from {src} to {dst} need PROJ's grid{'s' if len(grids) > 1 else ''} {', '.join(grids) or '(unknown)'}, "
            f"which {'are' if len(grids) > 1 else 'is'} not installed: fetch with 'projsync --file NAME' "
            "(or set PROJ_NETWORK=ON), or export heights relative to the take-off point")
    return group.transformers[0]


def ellipsoidal_and_egm96(frame: dict, local) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Longitude, latitude, WGS84 ellipsoidal height and EGM96 height of local points; needs a
    frame whose heights have a datum (a compound CRS or a vertical CRS) and PROJ's geoid grids.

    Parameters
    ----------
    frame : dict
        The route file's ``frame``.
    local : (n, 3) float
        Points in the local frame.

    Returns
    -------
    lon, lat, h_ellipsoid, h_egm96 : (n,) float
        Degrees and metres.
    """
    crs = frame.get("crs")
    vertical = frame.get("vertical_crs")
    if not crs or not (vertical or CRS.from_user_input(crs).is_compound):
        raise ParameterError("EGM96 heights need a scene whose heights have a datum: a city model with a vertical "
                             "CRS, or --crs with a compound CRS such as EPSG:7415; or export heights relative to the "
                             "take-off point")
    source = crs if not vertical or CRS.from_user_input(crs).is_compound else f"{crs}+{vertical.split(':')[-1]}"
    local = np.asarray(local, dtype=float).reshape(-1, 3)
    src = local + np.asarray(frame.get("origin") or [0.0, 0.0, 0.0], dtype=float)
    unit = float(frame.get("crs_unit_m", 1.0))
    lon, lat, h_ell = checked_transformer(source, "EPSG:4979").transform(src[:, 0] / unit, src[:, 1] / unit, src[:, 2])
    _lon, _lat, h_egm = checked_transformer("EPSG:4979", "EPSG:4326+5773").transform(lon, lat, h_ell)
    return np.asarray(lon), np.asarray(lat), np.asarray(h_ell), np.asarray(h_egm)


_GEOD = Geod(ellps="WGS84")


def grid_convergence(frame: dict, local) -> np.ndarray:
    """Azimuth (deg from true north) of the local +y axis at each point.

    Parameters
    ----------
    frame : dict
        The route file's ``frame``.
    local : (n, 3) float
        Points in the local frame.

    Returns
    -------
    (n,) float
        Degrees, clockwise from true north.
    """
    local = np.asarray(local, dtype=float).reshape(-1, 3)
    lon0, lat0, _ = to_lonlat(frame, local)
    lon1, lat1, _ = to_lonlat(frame, local + [0.0, 1.0, 0.0])
    azimuth, _back, _dist = _GEOD.inv(lon0, lat0, lon1, lat1)
    return np.asarray(azimuth)
