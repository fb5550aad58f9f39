"""One self-contained HTML file per plan: 3D view, coverage colours, road map, metrics.

three.js and its orbit controls are embedded (as data: URLs in an import map), so the file
opens offline in any current browser. Numeric arrays travel as base64 float32/uint8.
"""

from __future__ import annotations

import base64
import html
import json
from importlib import resources
from pathlib import Path

import numpy as np

from coverplan.evaluation import evaluate
from coverplan.io.footprints import extrude
from coverplan.report.frame import display_mesh, focus_bounds
from coverplan.report.plan_view import flight_colour, plan_view_svg
from coverplan.report.sections import (
    _rows,
    flights_section,
    headline,
    metrics_rows,
    path_legend,
    photos_section,
    road_map_rows,
    simulation_rows,
    uncovered_rows,
)
from coverplan.world.zones import Zones

MAX_TERRAIN_CELLS = 40_000
LEG_CODES = {"initial": 0, "coverage": 1, "final": 2}


def _b64(array, dtype) -> str:
    return base64.b64encode(np.ascontiguousarray(array, dtype=dtype).tobytes()).decode("ascii")


def _asset(name: str) -> str:
    return resources.files("coverplan.report").joinpath("assets", name).read_text(encoding="utf-8")


def report_data(route, scene, evaluation, simulation=None) -> dict:
    """Everything the viewer draws, as JSON-ready values.

    Parameters
    ----------
    route : Route
        The route drawn.
    scene : Scene
        Its scene.
    evaluation : Evaluation
        The evaluator's verdict.
    simulation : Simulation, optional
        Adds what SfM recovered.

    Returns
    -------
    dict
        Meshes, path, photos, zones and coverage for the viewer.
    """
    samples = evaluation.samples
    cam, pt, rng = evaluation.pairs
    best = np.full(len(samples), np.inf)
    np.minimum.at(best, pt, rng)
    gsd = np.where(np.isfinite(best), route.camera.gsd_at(best), -1.0)
    status = np.where(evaluation.covered | ~evaluation.reachable, 0, 1)
    status = np.where(evaluation.reachable, status, 2).astype(np.uint8)
    lo, hi = focus_bounds(route, scene)  # the initial view: the target and its flight, not the tile
    meshes = []
    for part in scene.parts:
        v, f = display_mesh(part.mesh)
        meshes.append({"name": part.name, "role": part.role, "positions": _b64(v, np.float32),
                       "indices": _b64(f, np.uint32)})
    if scene.terrain is not None:  # the ground under the picture's frame, not the whole DTM
        ground = scene.terrain.mesh_within(lo, hi, max_cells=MAX_TERRAIN_CELLS)
        meshes.append({"name": scene.terrain.source, "role": "terrain",
                       "positions": _b64(ground.vertices, np.float32), "indices": _b64(ground.faces, np.uint32)})
    for zone in Zones.from_list(route.params.get("zones")).zones:
        v, f = zone_prism(zone, lo[2], hi[2])
        meshes.append({"name": zone.label, "role": zone.kind, "positions": _b64(v, np.float32),
                       "indices": _b64(f, np.uint32)})
    extra = {}
    if simulation is not None:
        extra["simulation"] = {"reconstructed": _b64(simulation.reconstructed_at(samples.points), np.uint8),
                               "shot_registered": _b64(simulation.shot_registered, np.uint8)}
    return {
        **extra,
        "meshes": meshes,
        "samples": {"positions": _b64(samples.points, np.float32),
                    "views": _b64(np.minimum(evaluation.views, 255), np.uint8),
                    "gsd": _b64(gsd, np.float32), "status": _b64(status, np.uint8)},
        "waypoints": {"positions": _b64(route.positions, np.float32), "shot": _b64(route.shot, np.uint8),
                      "heading": _b64(route.heading_deg, np.float32), "pitch": _b64(route.pitch_deg, np.float32),
                      "leg": _b64([LEG_CODES[x] for x in route.leg], np.uint8),
                      "flight": _b64(route.flight, np.uint8)},
        "flight_colours": [flight_colour(k) for k in range(1, route.n_flights + 1)],
        "camera": {"hfov_deg": route.camera.hfov_deg, "vfov_deg": route.camera.vfov_deg},
        "params": {k: v for k, v in route.params.items() if isinstance(v, (int, float))},
        "centre": ((lo + hi) / 2).tolist(),
        "radius": float(np.linalg.norm(hi - lo) / 2),
        "sample_size": float(max(samples.spacing * 0.6, 0.05)),
        "frustum_depth": float(max(route.d_opt * 0.12, 0.3)),
    }


def zone_prism(zone, low: float, high: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (n, 3) and faces (m, 3) of a zone's prism, its open floor or ceiling cut at
    ``low`` / ``high`` (the picture's frame).

    Parameters
    ----------
    zone : Zone
        A keep-out or keep-in zone.
    low, high : float
        Heights in metres where open floors and ceilings are cut.

    Returns
    -------
    vertices : (n, 3) float
    faces : (m, 3) int
    """
    floor = zone.floor if np.isfinite(zone.floor) else low
    ceiling = zone.ceiling if np.isfinite(zone.ceiling) else high
    tri = np.vstack([extrude(p, max(ceiling - floor, 0.1), base=floor)
                     for p in getattr(zone.polygon, "geoms", [zone.polygon])])
    return tri.reshape(-1, 3), np.arange(len(tri) * 3).reshape(-1, 3)


def render_html(route, scene, evaluation, title: str = "coverplan flight report", simulation=None,
                check=None) -> str:
    """The whole report as one HTML page, its viewer's data inline.

    Parameters
    ----------
    route : Route
        The route reported.
    scene : Scene
        Its scene.
    evaluation : Evaluation
        Its verdict.
    title : str
        The page's title.
    simulation : Simulation, optional
        Adds what SfM recovered.
    check : Check, optional
        Adds a check of real photos.

    Returns
    -------
    str
        The page.
    """
    simulation = check.simulation if check is not None else simulation
    data = report_data(route, scene, evaluation, simulation)
    if check is None:
        reconstruction = f"<h2>Reconstruction (simulated photos, COLMAP)</h2>{simulation_rows(simulation)}"
    else:
        reconstruction = f"<h2>Reconstruction (the flight's photos, COLMAP)</h2>{photos_section(check)}"
    three = base64.b64encode(_asset("three.module.min.js").encode()).decode()
    orbit = base64.b64encode(_asset("OrbitControls.js").encode()).decode()
    import_map = {"imports": {"three": f"data:text/javascript;base64,{three}",
                              "three/addons/controls/OrbitControls.js": f"data:text/javascript;base64,{orbit}"}}
    cam = route.camera
    params = [("camera", f"{cam.name or 'custom'}: {cam.sensor_width_mm:g} × {cam.sensor_height_mm:g} mm, "
                         f"{cam.focal_length_mm:g} mm, {cam.image_width_px} × {cam.image_height_px} px"),
              ("GSD", f"{route.gsd * 1000:g} mm/px (d_opt {route.d_opt:.2f} m)"),
              ("security distance", f"{route.security:g} m"),
              ("min views / triangulation", f"{route.param('min_views')} / {route.param('min_triangulation_deg')}°"),
              ("max incidence", f"{route.param('max_incidence_deg')}°")]
    if "min_altitude_m" in route.params:
        params.append(("min altitude above ground", f"{route.params['min_altitude_m']:g} m"))
    pm = route.metrics or {}
    if pm.get("planning_time_s") is not None:
        params.append(("planning time", f"{pm['planning_time_s']:.2f} s"))
        stages = ", ".join(f"{k} {v:.2f} s" for k, v in pm.get("stage_seconds", {}).items())
        if stages:
            params.append(("stages", stages))
    if route.frame.get("crs"):
        params.append(("CRS / origin", f"{route.frame['crs']} / {route.frame['origin']}"))
    data_json = json.dumps(data).replace("</", "<\\/")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{html.escape(title)}</title>
<style>{_asset('report.css')}</style>
<script type="importmap">{json.dumps(import_map)}</script>
</head><body>
<header><h1>{html.escape(title)}</h1>
{headline(route, evaluation)}</header>
<main>
<div id="view"></div>
<div class="controls">
 <div>show:
  <label><input type=checkbox data-layer=targets checked>target</label>
  <label><input type=checkbox data-layer=obstacles checked>obstacles</label>
  {'<label><input type=checkbox data-layer=terrain checked>terrain</label>' if scene.terrain is not None else ''}
  {'<label><input type=checkbox data-layer=zones checked>zones</label>' if route.params.get("zones") else ''}
  <label><input type=checkbox data-layer=samples checked>coverage</label>
  <label><input type=checkbox data-layer=uncovered checked>uncovered</label>
  <label><input type=checkbox data-layer=path checked>path</label>
  <label><input type=checkbox data-layer=shots checked>shots</label>
  <label><input type=checkbox data-layer=start checked>start</label></div>
 <div>colour samples by:
  <label><input type=radio name=colour value=views checked>valid views</label>
  <label><input type=radio name=colour value=gsd>achieved GSD</label>
  {'<label><input type=radio name=colour value=sfm>reconstructed (COLMAP, 0.2 m)</label>' if simulation is not None else ''}</div>
 <div class=legend>views<span style="background:#e53e3e"></span>0<span style="background:#ed8936"></span>1
  <span style="background:#9ae6b4"></span>2<span style="background:#2f855a"></span>3+
  <span style="background:#d53f8c"></span>missed<span style="background:#553c9a"></span>unreachable
  &nbsp; {path_legend(route)}
  {'&nbsp; shots<span style="background:#1a202c"></span>registered<span style="background:#e53e3e"></span>lost by SfM' if simulation is not None else ''}</div>
</div>
<div class=cols>
<section><h2>Parameters</h2><table>{_rows(params)}</table></section>
<section><h2>Metrics</h2><table>{_rows(metrics_rows(evaluation.metrics))}</table></section>
<section><h2>Not covered, and why</h2><table><tr><th class=l>reason</th><th>samples</th><th>m²</th><th>around</th></tr>
{uncovered_rows(evaluation)}</table></section>
<section><h2>Flights ({route.n_flights})</h2>{flights_section(route)}</section>
<section class=wide><h2>Map</h2><p>The flight from above: each battery flight in its colour, its photos as dots,
H the take-off point; north and the scale as drawn.</p>{plan_view_svg(route, scene)}</section>
<section id=reconstruction>{reconstruction}</section>
</div>
<section><h2>Road map ({len(route)} waypoints)</h2>
<div class=scroll><table id="road-map"><thead><tr><th>#</th><th>flight</th><th>x</th><th>y</th><th>z</th><th>altitude</th>
<th>heading °</th><th>gimbal °</th><th class=l>shot</th><th class=l>leg</th></tr></thead>
<tbody>
{road_map_rows(route)}
</tbody></table></div></section>
</main>
<script type="application/json" id="report-data">{data_json}</script>
<script type="module">{_asset('viewer.js')}</script>
</body></html>
"""


def write_html_report(route, scene, path, evaluation=None, title: str | None = None, simulation=None,
                      check=None) -> Path:
    """Write the report for ``route`` in ``scene`` (evaluating it unless given); with a
    ``simulation`` it also shows what SfM recovered and which photos it lost; with a ``check``
    (``coverplan check``'s result) its verdict and every photo not in the model, with why.

    Parameters
    ----------
    route : Route
        The route reported.
    scene : Scene
        Its scene.
    path : str or Path
        The HTML file.
    evaluation : Evaluation, optional
        Evaluated here when None.
    title : str, optional
        The page's title.
    simulation : Simulation, optional
        A simulated reconstruction.
    check : Check, optional
        A check of real photos.

    Returns
    -------
    Path
        ``path``.
    """
    if evaluation is None:
        evaluation = evaluate(route, scene)
    path = Path(path)
    path.write_text(render_html(route, scene, evaluation, title or f"coverplan flight report: {path.stem}",
                                simulation=simulation, check=check),
                    encoding="utf-8")
    return path
