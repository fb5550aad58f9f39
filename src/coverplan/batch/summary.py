"""A batch's summary: ``summary.csv``, ``summary.geojson`` (footprints with each building's
row) and ``index.html`` (a map of the footprints coloured by result, linking every report)."""

from __future__ import annotations

import csv
import html
import io
from pathlib import Path

import numpy as np
import shapely

from coverplan.files import json_text, write_atomic
from coverplan.geometry.geo import to_lonlat

COLUMNS = ["id", "status", "shots", "path_length_m", "flight_time_min", "flights", "coverage_pct",
           "planned_coverage_pct", "uncovered_area_m2", "main_uncovered_reason", "min_clearance_m",
           "planning_time_s", "folder", "error"]


def write_summary(model, chosen, rows: list[dict], out_dir: Path, settings) -> list[Path]:
    """Write the three summary files for ``rows`` (one per building of ``chosen``).

    Parameters
    ----------
    model : CityModel
        The city model, for the buildings' footprints.
    chosen : list of CityObject
        The buildings planned.
    rows : list of dict
        Their summary rows, in the same order.
    out_dir : Path
        The batch's output folder.
    settings : BatchSettings
        The settings, recorded beside the rows.

    Returns
    -------
    list of Path
        The files written.
    """
    footprints = [model.footprint(obj, settings.lod) for obj in chosen]
    written = [write_atomic(out_dir / "summary.csv", _csv(rows))]
    written.append(write_atomic(out_dir / "summary.geojson", _geojson(model, footprints, rows)))
    written.append(write_atomic(out_dir / "index.html", _index(model, footprints, rows, out_dir)))
    return written


def _csv(rows: list[dict]) -> str:
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=COLUMNS, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: row.get(k, "") for k in COLUMNS})
    return buffer.getvalue()


def _geojson(model, footprints, rows) -> str:
    """RFC 7946 (longitude, latitude) when the file names its CRS, else the file's coordinates
    with a ``coordinates`` member saying so."""
    crs = model.crs[0]
    features = []
    for shape, row in zip(footprints, rows):
        geometry = shapely.geometry.mapping(shape)
        if crs:
            geometry = shapely.geometry.mapping(shapely.transform(shape, _to_lonlat(crs)))
        features.append({"type": "Feature", "geometry": _rounded(geometry),
                         "properties": {k: row.get(k) for k in COLUMNS}})
    doc = {"type": "FeatureCollection", "features": features}
    if not crs:
        doc["coordinates"] = f"{model.path.name}'s own (it names no CRS)"
    return json_text(doc, indent=None)


def _to_lonlat(crs: str):

    def transform(xy: np.ndarray) -> np.ndarray:
        # city coordinates are in the CRS's own units: no scaling, no local origin
        lon, lat, _ = to_lonlat({"crs": crs, "crs_unit_m": 1.0}, np.column_stack([xy, np.zeros(len(xy))]))
        return np.column_stack([lon, lat])
    return transform


def _rounded(geometry: dict) -> dict:
    def walk(c):
        if isinstance(c, (list, tuple)) and c and isinstance(c[0], (int, float)):
            return [round(float(v), 8) for v in c]
        return [walk(x) for x in c]
    return dict(geometry, coordinates=walk(geometry["coordinates"]))


STATUS_COLOURS = {"failed": "#d62728", "unsafe": "#ff7f0e", "not run": "#9e9e9e"}


def _colour(row: dict) -> str:
    if row.get("status") != "planned":
        return STATUS_COLOURS.get(row.get("status"), "#9e9e9e")
    pct = float(row.get("coverage_pct") or 0.0)
    if pct >= 99.5:
        return "#2ca02c"
    return "#bcbd22" if pct >= 95.0 else "#e6c229"


def _index(model, footprints, rows, out_dir: Path) -> str:
    """A self-contained page: an SVG map of the footprints (click one for its report) and the table."""
    bounds = np.array([s.bounds for s in footprints])
    lo, hi = bounds[:, :2].min(axis=0), bounds[:, 2:].max(axis=0)
    size = float(max(hi - lo)) or 1.0
    pad = 0.03 * size
    width = 900.0
    scale = width / (size + 2 * pad)
    view_h = (hi[1] - lo[1] + 2 * pad) * scale

    def svg_points(ring) -> str:
        xy = np.asarray(ring.coords)[:, :2]
        x = (xy[:, 0] - lo[0] + pad) * scale
        y = (hi[1] - xy[:, 1] + pad) * scale
        return " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(x, y))

    shapes = []
    for shape, row in zip(footprints, rows):
        polygons = getattr(shape, "geoms", [shape])
        outline = "".join(f'<polygon points="{svg_points(p.exterior)}"/>' for p in polygons if not p.is_empty)
        tip = html.escape(f"{row['id']}: {row.get('status')}"
                          + (f", {row.get('coverage_pct')} %, {row.get('shots')} shots"
                             if row.get("status") == "planned" else f" ({row.get('error', '')})"))
        group = f'<g fill="{_colour(row)}"><title>{tip}</title>{outline}</g>'
        report = Path("buildings") / str(row.get("folder")) / "report.html"
        if (out_dir / report).exists():
            group = f'<a href="{html.escape(report.as_posix())}">{group}</a>'
        shapes.append(group)
    table = []
    for row in rows:
        report = Path("buildings") / str(row.get("folder")) / "report.html"
        name = html.escape(str(row["id"]))
        link = f'<a href="{html.escape(report.as_posix())}">{name}</a>' if (out_dir / report).exists() else name
        cells = "".join(f"<td>{html.escape(str(row.get(k, '')))}</td>" for k in COLUMNS[1:-2])
        table.append(f'<tr><td><span class="dot" style="background:{_colour(row)}"></span>{link}</td>{cells}'
                     f"<td>{html.escape(str(row.get('error', '')))}</td></tr>")
    counts = {}
    for row in rows:
        counts[row.get("status")] = counts.get(row.get("status"), 0) + 1
    tally = ", ".join(f"{n} {status}" for status, n in sorted(counts.items()))
    header = "".join(f"<th>{c.replace('_', ' ')}</th>" for c in ["id", *COLUMNS[1:-2], "error"])
    title = html.escape(f"coverplan batch: {model.path.name}")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<style>
body {{ font-family: system-ui, sans-serif; margin: 1.5em; color: #222; }}
svg {{ border: 1px solid #ccc; background: #fafafa; max-width: 100%; height: auto; }}
svg polygon {{ stroke: #333; stroke-width: 0.6; }}
svg a:hover polygon {{ stroke-width: 2; }}
table {{ border-collapse: collapse; font-size: 0.85em; margin-top: 1em; }}
th, td {{ border-bottom: 1px solid #ddd; padding: 0.2em 0.6em; text-align: right; }}
th:first-child, td:first-child, td:last-child {{ text-align: left; }}
.dot {{ display: inline-block; width: 0.8em; height: 0.8em; border-radius: 50%; margin-right: 0.4em; }}
</style></head><body>
<h1>{title}</h1>
<p>{len(rows)} buildings: {html.escape(tally)}. Green: covered ≥ 99.5 %, yellow: less,
orange: unsafe by the evaluator, red: failed, grey: not run. Click a building for its flight report.
Rows are also in <a href="summary.csv">summary.csv</a> and <a href="summary.geojson">summary.geojson</a>.</p>
<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {width:.0f} {view_h:.0f}" width="{width:.0f}">
{''.join(shapes)}
</svg>
<table><thead><tr>{header}</tr></thead><tbody>
{''.join(table)}
</tbody></table>
</body></html>
"""
