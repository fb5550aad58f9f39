"""Where the flight starts: a safe point beside the target, or the user's, checked."""

from __future__ import annotations

import numpy as np

from coverplan.errors import ParameterError, PlanningError
from coverplan.shots.limits import ViewLimits
from coverplan.world.zones import KEEP_OUT


def default_start(scene, limits: ViewLimits, margin: float) -> np.ndarray:
    """A point just outside the shot region, north-west of the target, at the minimum altitude.

    Parameters
    ----------
    scene : Scene
        The scene.
    limits : ViewLimits
        Security distance, altitude band and zones.
    margin : float
        Metres beyond the shot region.

    Returns
    -------
    (3,) float
        The take-off point, local frame.
    """
    lo, hi = scene.bounds("target")
    clearance = scene.clearance_model(limits.security)
    centre = (lo + hi) / 2.0
    # With zones, nearer rings too: a keep-in zone round the property may be tight.
    steps = np.arange(0.25, 20.0, 0.25) if limits.zones else np.arange(1.0, 20.0, 1.0)
    for extra in steps * max(limits.d_opt, 1.0):
        angles = np.radians(np.arange(135.0, 135.0 + 360.0, 15.0))
        r = np.linalg.norm(hi[:2] - lo[:2]) / 2.0 + extra
        xy = np.column_stack([centre[0] + r * np.cos(angles), centre[1] + r * np.sin(angles)])
        pts = np.column_stack([xy, limits.floor_at(xy)])
        ok = clearance.points_clear(pts, limits.security + margin)
        if limits.zones:
            ok &= limits.zones.points_allowed(pts)
        if ok.any():
            return pts[np.argmax(ok)]
    raise PlanningError("found no safe start point near the target" + (" outside the keep-out zones and inside the "
                        "keep-in zone" if limits.zones else "") + "; give one with --start X Y Z")


def start_from_latlon(scene, latlon) -> np.ndarray:
    """The take-off point given in WGS84 as a point of the scene's local frame.

    Parameters
    ----------
    scene : Scene
        A georeferenced scene (a CRS or a geodetic origin).
    latlon : sequence of 2 or 3 float
        Latitude and longitude in degrees, optionally the height above the ground there in m
        (default 0: on the ground; ``check_start`` raises it to the lowest flight height).

    Returns
    -------
    (3,) float
        The point in the local frame, on or above the ground under it.

    Raises
    ------
    ParameterError
        Without a georeference, with other than 2 or 3 values, or with a latitude or longitude
        out of range (given the wrong way round, most often).
    """
    from coverplan.geometry.geo import from_lonlat, has_georeference

    values = [float(v) for v in latlon]
    if len(values) not in (2, 3):
        raise ParameterError(f"--start-latlon takes LAT LON [H], got {len(values)} values")
    lat, lon, above = values + [0.0] * (3 - len(values))
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        raise ParameterError(f"--start-latlon {lat:g} {lon:g}: latitude must be within +-90 and longitude within "
                             "+-180 degrees (latitude first)")
    if not has_georeference(scene.frame):
        raise ParameterError("--start-latlon needs a georeferenced scene: a CityGML/CityJSON file, or "
                             "--crs EPSG:XXXX or --geo-origin LAT LON H")
    height = float(scene.geodetic_origin[2]) if scene.geodetic_origin else 0.0
    local = from_lonlat(scene.frame, [lon], [lat], [height]).reshape(3)
    lo, hi = scene.bounds("target")
    away = float(np.linalg.norm(np.maximum(np.maximum(lo[:2] - local[:2], local[:2] - hi[:2]), 0.0)))
    if away > MAX_START_DISTANCE_M:
        from coverplan.geometry.geo import to_lonlat
        lon0, lat0, _ = to_lonlat(scene.frame, ((lo + hi) / 2.0)[None])
        raise ParameterError(f"--start-latlon {lat:g} {lon:g} is {away / 1000:,.0f} km from the target, which is at "
                             f"{lat0[0]:.5f} {lon0[0]:.5f} (latitude first)")
    local[2] = float(scene.ground_at(local[None, :2])[0]) + above
    return local


MAX_START_DISTANCE_M = 5_000.0  # farther than any battery flies: a coordinate mix-up


def check_start(scene, start, limits: ViewLimits) -> tuple[np.ndarray, list[str]]:
    """The start point given, raised to the minimum altitude, refused inside or near a mesh or far
    from the target; returns it with notes on what was changed.

    Parameters
    ----------
    scene : Scene
        The scene.
    start : (3,) float
        The take-off point asked for, local frame.
    limits : ViewLimits
        Security distance, altitude band and zones.

    Returns
    -------
    start : (3,) float
        The take-off point used.
    notes : list of str
        What was changed.

    Raises
    ------
    ParameterError
        A point that is not three finite numbers, far from the target, or on the wrong side of a zone.
    PlanningError
        A point inside a mesh or closer to one than the security distance.
    """
    notes = []
    start = np.asarray(start, dtype=float).reshape(3)
    if not np.isfinite(start).all():
        raise ParameterError(f"start point must be three finite numbers, got {start.tolist()}")
    lo, hi = scene.bounds("target")
    away = float(np.linalg.norm(np.maximum(np.maximum(lo - start, start - hi), 0.0)))
    if away > MAX_START_DISTANCE_M:
        centre = scene.to_source((lo + hi) / 2.0)
        raise ParameterError(
            f"start point is {away / 1000:,.0f} km from the target; give it in the same coordinates as the input "
            f"models (the target's centre is at {', '.join(f'{v:.1f}' for v in centre)})")
    floor = float(limits.floor_at(start[None, :2])[0])
    if start[2] < floor:
        notes.append(f"start raised from z={start[2]:.2f} to the minimum altitude z={floor:.2f}"
                     + (" above the terrain" if limits.terrain is not None else ""))
        start = start.copy()
        start[2] = floor
    breach = limits.zones.point_breaches(start[None])[0] if limits.zones else -1
    if breach >= 0:
        zone = limits.zones.zones[breach]
        where = "inside" if zone.kind == KEEP_OUT else "outside"
        raise ParameterError(f"start point {start.round(2).tolist()} is {where} {zone.label}; "
                             + ("start outside it" if zone.kind == KEEP_OUT else "the flight must start inside it"))
    inside = scene.rays.inside(start[None])[0]
    if inside >= 0:
        raise PlanningError(f"start point {start.round(2).tolist()} is inside {scene.describe(int(inside))}")
    clearance = scene.clearance_model(limits.security)
    d, which = clearance.point_distance(start[None])
    if d[0] < limits.security:
        raise PlanningError(f"start point {start.round(2).tolist()} is {d[0]:.2f} m from "
                            f"{scene.describe(int(which[0]))}, closer than the security distance "
                            f"{limits.security:g} m")
    return start, notes
