"""GeoJSON (RFC 7946): the flight as a LineString and each waypoint as a Point with properties.

Coordinates are longitude, latitude and height; heights are above sea level when the route's
frame knows its datum, else above the take-off point (the member ``altitude_reference`` says
which)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from coverplan.files import write_atomic
from coverplan.io.geoflight import geo_flight, geo_zones
from coverplan.io.registry import register_writer


@register_writer("geojson", ".geojson")
def write_geojson(route, path, **_ignored) -> list[Path]:
    """Write the route as GeoJSON: the path as a LineString, each waypoint as a Point, the zones as polygons.

    Parameters
    ----------
    route : Route
        The route (one battery flight).
    path : str or Path
        The file.
    **_ignored
        Options of other writers.

    Returns
    -------
    list of Path
        The file written.
    """
    f = geo_flight(route)
    alt = f.alt_abs if f.alt_abs is not None else f.alt_rel
    coords = [[round(float(f.lon[k]), 9), round(float(f.lat[k]), 9), round(float(alt[k]), 3)] for k in range(len(f))]
    features = [{"type": "Feature", "geometry": {"type": "LineString", "coordinates": coords},
                 "properties": {"name": "flight", "shots": int(f.shot.sum())}}]
    for k in range(len(f)):
        features.append({"type": "Feature", "geometry": {"type": "Point", "coordinates": coords[k]},
                         "properties": {"index": k, "shot": bool(f.shot[k]), "leg": f.leg[k],
                                        "heading_deg": round(float(f.heading_true[k]), 3),
                                        "gimbal_pitch_deg": round(float(f.pitch[k]), 3),
                                        "altitude_above_takeoff_m": round(float(f.alt_rel[k]), 3)}})
    for zone in geo_zones(route):
        rings = [[[[round(float(a), 9), round(float(b), 9)] for a, b in np.vstack([r, r[:1]])] for r in poly]
                 for poly in zone.polygons]
        features.append({"type": "Feature", "geometry": {"type": "MultiPolygon", "coordinates": rings},
                         "properties": {"name": zone.name, "zone": zone.kind}})
    doc = {"type": "FeatureCollection", "features": features,
           "altitude_reference": "sea level" if f.alt_abs is not None else "take-off point"}
    return [write_atomic(path, json.dumps(doc))]
