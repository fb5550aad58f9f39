"""Plain CSV of the waypoints in local metres (plus WGS84 where the route is georeferenced)."""

from __future__ import annotations

import csv
import io
from pathlib import Path

from coverplan.files import write_atomic
from coverplan.geometry import geo
from coverplan.io.registry import register_writer

COLUMNS = ["index", "x_m", "y_m", "z_m", "altitude_above_ground_m", "heading_deg", "gimbal_pitch_deg", "shot", "leg"]


@register_writer("csv", ".csv")
def write_csv(route, path, **_ignored) -> list[Path]:
    lonlat = geo.to_lonlat(route.frame, route.positions) if geo.has_georeference(route.frame) else None
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(COLUMNS + (["longitude", "latitude"] if lonlat else []))
    above_ground = route.above_ground()
    for k in range(len(route)):
        x, y, z = route.positions[k]
        row = [k, f"{x:.4f}", f"{y:.4f}", f"{z:.4f}", f"{above_ground[k]:.4f}", f"{route.heading_deg[k]:.3f}",
               f"{route.pitch_deg[k]:.3f}", int(route.shot[k]), route.leg[k]]
        if lonlat:
            row += [f"{lonlat[0][k]:.9f}", f"{lonlat[1][k]:.9f}"]
        writer.writerow(row)
    return [write_atomic(path, buffer.getvalue())]
