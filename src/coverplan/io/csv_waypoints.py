"""Plain CSV of the waypoints in local metres (plus WGS84 and true heading where the route is
georeferenced), and its reader: evaluate takes the file back as a mission."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from coverplan.errors import InputFileError
from coverplan.files import write_atomic
from coverplan.flight.missions import GROUND, MissionBuilder
from coverplan.geometry import geo
from coverplan.io.registry import register_writer

GEO_COLUMNS = ["longitude", "latitude", "heading_true_deg"]
COLUMNS = ["index", "x_m", "y_m", "z_m", "altitude_above_ground_m", "heading_deg", "gimbal_pitch_deg", "shot", "leg"]


@register_writer("csv", ".csv")
def write_csv(route, path, **_ignored) -> list[Path]:
    """Write the route as coverplan's CSV: one row per waypoint (``COLUMNS``, then WGS 84 ones when georeferenced).

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
    geo_cols = None
    if geo.has_georeference(route.frame):
        from coverplan.io.geoflight import geo_flight
        f = geo_flight(route)
        geo_cols = (f.lon, f.lat, f.heading_true)
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(COLUMNS + (GEO_COLUMNS if geo_cols else []))
    above_ground = route.above_ground()
    for k in range(len(route)):
        x, y, z = route.positions[k]
        row = [k, f"{x:.4f}", f"{y:.4f}", f"{z:.4f}", f"{above_ground[k]:.4f}", f"{route.heading_deg[k]:.3f}",
               f"{route.pitch_deg[k]:.3f}", int(route.shot[k]), route.leg[k]]
        if geo_cols:
            row += [f"{geo_cols[0][k]:.9f}", f"{geo_cols[1][k]:.9f}", f"{geo_cols[2][k]:.3f}"]
        writer.writerow(row)
    return [write_atomic(path, buffer.getvalue())]


def is_waypoint_csv(path) -> bool:
    """Whether a .csv file is this writer's (its header starts with ``COLUMNS``).

    Parameters
    ----------
    path : str or Path
        A .csv file.

    Returns
    -------
    bool
        True for coverplan's CSV.
    """
    with open(path, encoding="utf-8", errors="replace") as fh:
        return fh.readline().strip().split(",")[:len(COLUMNS)] == COLUMNS


def read_waypoint_csv(path):
    """coverplan's own CSV as a mission: WGS84 positions, heights above the ground under each
    waypoint, true headings, gimbal pitches and photos.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    Mission
        The flight as flown.

    Raises
    ------
    InputFileError
        When the file has no WGS84 columns (its route had no georeference).
    """
    with open(path, encoding="utf-8", newline="") as fh:
        rows = list(csv.DictReader(fh))
    if not rows or any(c not in rows[0] for c in GEO_COLUMNS):
        raise InputFileError(path, "is coverplan's CSV of a route without a georeference (no longitude/latitude); "
                                   "evaluate the route's .json instead")
    b = MissionBuilder(path, "coverplan CSV")
    for k, row in enumerate(rows, start=2):
        try:
            lat, lon, alt = float(row["latitude"]), float(row["longitude"]), float(row["altitude_above_ground_m"])
            heading, pitch, shot = float(row["heading_true_deg"]), float(row["gimbal_pitch_deg"]), row["shot"] == "1"
        except (TypeError, ValueError):
            raise InputFileError(path, f"line {k}: latitude, longitude, altitude_above_ground_m, heading_true_deg "
                                       "and gimbal_pitch_deg must be numbers") from None
        b.waypoint(lat, lon, alt, GROUND, heading=heading)
        b.pitch = pitch if np.isfinite(pitch) else b.pitch
        if shot:
            b.photo()
    return b.build(home=(float(rows[0]["latitude"]), float(rows[0]["longitude"])))
