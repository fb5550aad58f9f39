"""Litchi mission CSV (its documented columns). Litchi holds at most 99 waypoints per mission,
so longer flights are split into consecutive missions NAME.litchi.csv, NAME.litchi.2.csv, ...
Shots at one spot with different headings share a waypoint: rotate, tilt, photo actions."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from coverplan.errors import InputFileError
from coverplan.files import write_atomic
from coverplan.flight.missions import GROUND, TAKEOFF, MissionBuilder
from coverplan.io.csv_waypoints import is_waypoint_csv, read_waypoint_csv
from coverplan.io.geoflight import geo_flight
from coverplan.io.registry import register_mission_reader, register_writer

MAX_WAYPOINTS = 99
MAX_ACTIONS = 15
SAME_SPOT_M = 0.5
TAKE_PHOTO, ROTATE_AIRCRAFT, TILT_CAMERA, NO_ACTION = 1, 4, 5, -1
HEADER = (["latitude", "longitude", "altitude(m)", "heading(deg)", "curvesize(m)", "rotationdir", "gimbalmode",
           "gimbalpitchangle"]
          + [name for k in range(1, MAX_ACTIONS + 1) for name in (f"actiontype{k}", f"actionparam{k}")]
          + ["altitudemode", "speed(m/s)", "poi_latitude", "poi_longitude", "poi_altitude(m)", "poi_altitudemode",
             "photo_timeinterval", "photo_distinterval"])


def litchi_waypoints(route) -> list[dict]:
    """Waypoints with their actions; consecutive ones closer than 0.5 m are merged, and those
    without a photo where the path runs straight on (turn points) left out.

    Parameters
    ----------
    route : Route
        The route (one battery flight).

    Returns
    -------
    list of dict
        Position, heights, heading, pitch and actions per waypoint.
    """
    f = geo_flight(route)
    local = route.positions
    straight = route.straight_points()  # Litchi stops at every waypoint: none where the path runs on
    out: list[dict] = []
    for k in range(len(f)):
        if straight[k]:
            continue
        actions = []
        if f.shot[k]:
            actions = [(ROTATE_AIRCRAFT, round(float(f.heading_true[k]), 1)),
                       (TILT_CAMERA, round(float(f.pitch[k]), 1)), (TAKE_PHOTO, 0)]
        if out and np.linalg.norm(local[k] - out[-1]["local"]) < SAME_SPOT_M and \
                len(out[-1]["actions"]) + len(actions) <= MAX_ACTIONS:
            out[-1]["actions"] += actions
            continue
        out.append({"lat": float(f.lat[k]), "lon": float(f.lon[k]), "alt": float(f.alt_rel[k]),
                    "heading": float(f.heading_true[k]), "pitch": float(np.clip(f.pitch[k], -90, 30)),
                    "actions": actions, "local": local[k]})
    return out


@register_writer("litchi", ".litchi.csv")
def write_litchi(route, path, speed: float = 5.0, **_ignored) -> list[Path]:
    """Write the route as Litchi waypoint CSV, split into missions of at most 99 waypoints.

    Parameters
    ----------
    route : Route
        The route (one battery flight).
    path : str or Path
        The first file; later ones are NAME.litchi.2.csv and so on.
    speed : float
        Cruise speed, m/s.
    **_ignored
        Options of other writers.

    Returns
    -------
    list of Path
        The files written.
    """
    waypoints = litchi_waypoints(route)
    path = Path(path)
    written = []
    # Each later mission starts where the previous one ended.
    chunks, start = [], 0
    while start < len(waypoints) - 1 or not chunks:
        chunks.append(waypoints[start:start + MAX_WAYPOINTS])
        start += MAX_WAYPOINTS - 1
    for n, chunk in enumerate(chunks, start=1):
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(HEADER)
        for w in chunk:
            acts = (w["actions"] + [(NO_ACTION, 0)] * MAX_ACTIONS)[:MAX_ACTIONS]
            writer.writerow([f"{w['lat']:.8f}", f"{w['lon']:.8f}", f"{w['alt']:.2f}", f"{w['heading']:.1f}", 0, 0, 2,
                             f"{w['pitch']:.1f}", *[v for a in acts for v in a], 0, f"{speed:g}", 0, 0, 0, 0, -1, -1])
        target = path if n == 1 else path.with_name(path.name.replace(".litchi.csv", f".litchi.{n}.csv"))
        written.append(write_atomic(target, buffer.getvalue()))
    return written


# -- reading, for the evaluator ------------------------------------------------------------

def _litchi_rows(path):

    text = Path(path).read_text(encoding="utf-8-sig")
    rows = list(csv.reader(io.StringIO(text)))
    if not rows or [c.strip() for c in rows[0][:4]] != HEADER[:4]:
        raise InputFileError(path, "is not a Litchi mission CSV (header latitude,longitude,altitude(m),heading(deg),...)")
    head = [c.strip() for c in rows[0]]
    return head, [r for r in rows[1:] if any(c.strip() for c in r)]


def _parts(path: Path) -> list[Path]:
    """NAME.litchi.csv and the missions our writer split off it (NAME.litchi.2.csv, ...)."""
    parts = [path]
    if path.name.lower().endswith(".litchi.csv"):
        stem = path.name[: -len(".litchi.csv")]
        n = 2
        while (path.with_name(f"{stem}.litchi.{n}.csv")).exists():
            parts.append(path.with_name(f"{stem}.litchi.{n}.csv"))
            n += 1
    return parts


@register_mission_reader("csv")
def read_litchi(path):
    """A Litchi waypoint mission; split missions NAME.litchi.N.csv are read after NAME.litchi.csv.

    Altitudes: altitudemode 0 is above the take-off point, 1 above the ground below the
    waypoint, which on a flat site is the same; actions rotate the aircraft, tilt the gimbal
    and take photos in order, the waypoint's own heading and gimbal pitch apply otherwise.

    Parameters
    ----------
    path : str or Path
        The first file.

    Returns
    -------
    Mission
        The flight as Litchi flies it.
    """

    path = Path(path)
    if is_waypoint_csv(path):  # coverplan's own CSV export
        return read_waypoint_csv(path)
    parts = _parts(path)
    b = MissionBuilder(path, "Litchi mission")
    if len(parts) > 1:
        b.notes.append(f"read {len(parts)} Litchi missions in a row: {', '.join(p.name for p in parts)}")
    above_ground = False
    curved = False
    for part in parts:
        head, rows = _litchi_rows(part)
        col = {name: k for k, name in enumerate(head)}
        for k, row in enumerate(rows, start=2):
            def value(name, default=float("nan")):
                try:
                    return float(row[col[name]])
                except (KeyError, IndexError, ValueError):
                    return default
            lat, lon, alt = value("latitude"), value("longitude"), value("altitude(m)")
            if not np.isfinite([lat, lon, alt]).all():
                raise InputFileError(part, f"line {k}: latitude, longitude and altitude(m) must be numbers")
            ground_mode = value("altitudemode", 0.0) == 1
            above_ground |= ground_mode
            curved |= value("curvesize(m)", 0.0) > 0
            if value("gimbalmode", 2.0) == 2:
                b.pitch = value("gimbalpitchangle")
            b.waypoint(lat, lon, alt, GROUND if ground_mode else TAKEOFF, heading=value("heading(deg)"))
            for a in range(1, MAX_ACTIONS + 1):
                kind, param = value(f"actiontype{a}", NO_ACTION), value(f"actionparam{a}", 0.0)
                if kind == ROTATE_AIRCRAFT:
                    b.heading = param
                elif kind == TILT_CAMERA:
                    b.pitch = param
                elif kind == TAKE_PHOTO:
                    b.photo()
    if above_ground:
        b.notes.append("altitudes above ground (altitudemode 1) taken above the ground under each waypoint "
                       "(the terrain's with --terrain, else the scene's flat ground)")
    if curved:
        b.notes.append("curved turns (curvesize) are flown as straight lines between waypoints")
    first = b.rows[0] if b.rows else None
    return b.build(home=(first[0], first[1]) if first else None)
