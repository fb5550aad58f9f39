"""Where the pilot stands: the take-off point in the model's frame and on the map."""

from __future__ import annotations

import numpy as np

from coverplan.geometry.geo import has_georeference, to_lonlat


def map_link(lat: float, lon: float) -> str:
    """A link that opens the point in the phone's or the browser's map application.

    Parameters
    ----------
    lat, lon : float
        WGS 84 degrees.

    Returns
    -------
    str
        The URL.
    """
    return f"https://www.google.com/maps/search/?api=1&query={lat:.6f},{lon:.6f}"


def takeoff_point(route) -> dict:
    """The route's take-off point (its first waypoint) on the ground under it.

    Parameters
    ----------
    route : Route

    Returns
    -------
    dict
        ``local`` (3,) float: the point in the route's local frame, on the ground;
        ``model`` (3,) float: the same in the input models' coordinates; ``hover_m``: the height
        above the ground of the first waypoint; ``lat``, ``lon`` (degrees, WGS84) and ``map``
        (a link) when the route is georeferenced, else None.
    """
    first = np.asarray(route.positions[0], dtype=float)
    ground = float(route.ground_z[0]) if route.ground_z is not None else route.takeoff_z
    local = np.array([first[0], first[1], ground])
    model = local + np.asarray(route.frame.get("origin") or [0.0, 0.0, 0.0], dtype=float)
    point = {"local": local, "model": model, "hover_m": float(first[2] - ground), "lat": None, "lon": None,
             "map": None}
    if has_georeference(route.frame):
        lon, lat, _ = to_lonlat(route.frame, local[None])
        point.update(lat=float(lat[0]), lon=float(lon[0]), map=map_link(float(lat[0]), float(lon[0])))
    return point


def takeoff_text(point: dict) -> str:
    """One line: latitude/longitude (when known) and the model's coordinates of the take-off point.

    Parameters
    ----------
    point : dict
        ``model``: (x, y, z) in the model's coordinates; ``lat`` and ``lon``: degrees or None.

    Returns
    -------
    str
        The line.
    """
    x, y, z = point["model"]
    model = f"x {x:,.2f}, y {y:,.2f}, z {z:,.2f} in the model's coordinates"
    if point["lat"] is None:
        return f"{model} (no georeference: --crs or --geo-origin give its latitude and longitude)"
    lat, lon = point["lat"], point["lon"]
    return f"{abs(lat):.6f} {'N' if lat >= 0 else 'S'}, {abs(lon):.6f} {'E' if lon >= 0 else 'W'} ({model})"
