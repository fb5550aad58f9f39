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

from coverplan.equipment.flighttime import FlightModel
from coverplan.evaluation import evaluate
from coverplan.flight.battery import flight_table
from coverplan.io.footprints import extrude
from coverplan.report.frame import display_mesh, focus_bounds
from coverplan.report.plan_view import flight_colour, plan_view_svg
from coverplan.report.takeoff import takeoff_point, takeoff_text
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


def _fmt(v) -> str:
    if v is None:
        return "–"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:,.3f}" if abs(v) < 10 else f"{v:,.1f}"
    return html.escape(str(v))


def _rows(pairs) -> str:
    return "\n".join(f"<tr><td class=l>{html.escape(str(k))}</td><td>{v}</td></tr>" for k, v in pairs)


def metrics_rows(m: dict) -> list[tuple[str, str]]:
    """The report's metrics table: a label and a formatted value per metric.

    Parameters
    ----------
    m : dict
        ``Evaluation.metrics``.

    Returns
    -------
    list of (str, str)
        Label and value of each row.
    """
    def stats(s, unit=""):
        return " / ".join(_fmt(s[k]) for k in ("min", "mean", "max")) + unit
    safe = "yes" if m["safe"] else "<span class=bad>NO</span>"
    rows = [("safe", safe),
            ("min clearance", f"{_fmt(m['min_clearance_m'])} m (security {_fmt(m['security_m'])} m)"),
            ("unsafe segments", _fmt(m["unsafe_segment_count"])),
            ("altitude violations", f"{_fmt(m['altitude_violations'])} waypoints, "
                                    f"{_fmt(m.get('segments_below_min_altitude_count', 0))} segments"),
            ("lowest above " + ("the terrain" if m.get("terrain") else "the ground"),
             f"{_fmt(m.get('lowest_above_ground_m'))} m"),
            *([("zones", ", ".join(f"{z['kind']} {html.escape(z['name'])}" for z in m["zones"])),
               ("waypoints or segments breaching a zone", _fmt(m["zone_breach_count"]))] if m.get("zones") else []),
            ("coverage of reachable surface", f"{m['coverage_pct']:.2f} %"),
            ("reachable / total surface", f"{m['reachable_area_m2']:,.1f} / {m['surface_area_m2']:,.1f} m²"),
            ("uncovered reachable", f"{m['uncovered_reachable_area_m2']:,.1f} m²"),
            ("unreachable", f"{m['unreachable_area_m2']:,.1f} m²")]
    rows += [(f"coverage of {k.replace('_', ' ')}", f"{v:.2f} %") for k, v in m["coverage_by_class_pct"].items()]
    rows += [("shots", _fmt(m["shots"])), ("path length", f"{m['path_length_m']:,.1f} m"),
             ("nt-imaged (min / mean / max)", stats(m["nt_imaged"])),
             ("d-image (min / mean / max)", stats(m["d_image_m"], " m")),
             ("db-viewpoints (min / mean / max)", stats(m["db_viewpoints_m"], " m")),
             ("p-outliers", _fmt(m["p_outliers"])), ("shots per m²", f"{m['shots_per_m2']:.4f}"),
             ("path m per m²", f"{m['path_m_per_m2']:.4f}")]
    return rows


def road_map_rows(route) -> str:
    """The table rows of each flight's legs: from where to where, length and photos.

    Parameters
    ----------
    route : Route
        The route reported.

    Returns
    -------
    str
        HTML table rows.
    """
    rows = []
    above = route.above_ground()
    for k in range(len(route)):
        x, y, z = route.positions[k]
        shot = "yes" if route.shot[k] else ""
        rows.append(f"<tr><td>{k}</td><td>{route.flight[k]}</td><td>{x:.2f}</td><td>{y:.2f}</td><td>{z:.2f}</td><td>{above[k]:.2f}</td>"
                    f"<td>{route.heading_deg[k]:.1f}</td><td>{route.pitch_deg[k]:.1f}</td><td class=l>{shot}</td>"
                    f"<td class=l>{route.leg[k]}</td></tr>")
    return "\n".join(rows)


def flights_section(route) -> str:
    """Each battery flight in its colour: minutes flown through (as the WPML and QGroundControl
    exports fly) and stopping at every photo, photos, path, share of the limit.

    Parameters
    ----------
    route : Route
        The route reported.

    Returns
    -------
    str
        An HTML section.
    """
    model = FlightModel(**(route.metrics or {}).get("flight_model", {}))
    limit = route.params.get("max_flight_min")
    through = (route.metrics or {}).get("fly_through") if route.flies_through else None
    table = flight_table(route, model, limit)
    passing = (through or {}).get("flight_minutes") or [None] * len(table)
    rows = []
    for f, flown in zip(table, passing):
        share = f"{f['limit_share_pct']:.0f} %" if f["limit_share_pct"] is not None else "no limit set"
        swatch = f'<span class=swatch style="background:{flight_colour(f["flight"])}"></span>'
        rows.append(f"<tr><td>{swatch}{f['flight']}</td><td>{'–' if flown is None else f'{flown:.1f}'}</td>"
                    f"<td>{f['minutes']:.1f}</td><td>{f['shots']}</td>"
                    f"<td>{f['waypoints']}</td><td>{f['path_m']:,.0f}</td><td>{share}</td></tr>")
    drone = route.params.get("drone")
    how = (f"{model.cruise_speed:g} m/s between waypoints, {model.photo_seconds:g} s per photo when stopping"
           + (f", drone {html.escape(drone)}" if drone else "") + (f"; limit {limit:g} min per flight" if limit else ""))
    return (f"<p>Minutes by the flight-time model ({how}; docs/flights.md): flown through, taking photos in "
            "passing where the route allows it, and stopping at every photo (as Litchi flies). Every flight takes "
            "off from the start point and lands there.</p><table class=flights><tr><th>flight</th>"
            "<th>min flown through</th><th>min stopping</th><th>photos</th><th>waypoints</th><th>path m</th>"
            f"<th>of the limit</th></tr>{''.join(rows)}</table>")


def path_legend(route) -> str:
    """The path's colours: by leg for one flight, by battery flight for several.

    Parameters
    ----------
    route : Route
        The route reported.

    Returns
    -------
    str
        HTML of the legend.
    """
    if route.n_flights > 1:
        return "flights" + "".join(f'<span style="background:{flight_colour(k)}"></span>{k}'
                                   for k in range(1, route.n_flights + 1))
    return ('path<span style="background:#2b6cb0"></span>initial<span style="background:#dd6b20"></span>coverage'
            '<span style="background:#805ad5"></span>final')


def headline(route, evaluation) -> str:
    """The report's first lines: photos, flights and both times, coverage, clearance, take-off.

    Parameters
    ----------
    route : Route
        The route reported.
    evaluation : Evaluation
        Its verdict.

    Returns
    -------
    str
        An HTML paragraph.
    """
    m = evaluation.metrics
    minutes = [f["minutes"] for f in (route.metrics or {}).get("flights") or []]
    through = (route.metrics or {}).get("fly_through") if route.flies_through else None
    times = (f"{through['minutes']:.1f} min flown through ({sum(minutes):.1f} min stopping at every photo)"
             if through else f"{sum(minutes):.1f} min" if minutes else "")
    flights = f"{route.n_flights} battery flights" if route.n_flights > 1 else "1 flight"
    point = takeoff_point(route)
    where = html.escape(takeoff_text(point))
    if point["map"]:
        where += f' — <a class=map-link href="{html.escape(point["map"])}">open on a map</a>'
    return (f"<p>{m['shots']} photos, {flights}{', ' + times if times else ''}, {route.path_length:,.0f} m of "
            f"flight; {m['coverage_pct']:.2f} % of the reachable surface covered, closest approach "
            f"{m['min_clearance_m']:.2f} m{'' if evaluation.safe else ' — <b>UNSAFE</b>'}</p>"
            f"<p class=takeoff>take-off: {where}</p>")


def uncovered_rows(evaluation) -> str:
    """The table rows of the surface left uncovered, by part and by reason.

    Parameters
    ----------
    evaluation : Evaluation
        The evaluator's verdict.

    Returns
    -------
    str
        HTML table rows.
    """
    groups = evaluation.metrics["unreachable"]
    rows = [f"<tr><td class=l>{html.escape(g['reason'])}</td><td>{g['count']}</td><td>{g['area_m2']:.1f}</td>"
            f"<td>({', '.join(f'{c:.1f}' for c in g['centroid'])})</td></tr>" for g in groups]
    missed = evaluation.metrics["uncovered_reachable_samples"]
    if missed:
        rows.append(f"<tr><td class=l>reachable but not covered by this route</td><td>{missed}</td>"
                    f"<td>{evaluation.metrics['uncovered_reachable_area_m2']:.1f}</td><td></td></tr>")
    return "\n".join(rows) or "<tr><td class=l>nothing: every sample is covered</td><td></td><td></td><td></td></tr>"


def simulation_rows(sim) -> str:
    """The reconstruction table of a simulation, or a line saying how to get one.

    Parameters
    ----------
    sim : Simulation or None
        The simulated reconstruction.

    Returns
    -------
    str
        HTML.
    """
    if sim is None:
        return ("<p>No simulation: <code>coverplan simulate ROUTE --target ... -o DIR</code> renders the photos, "
                "reconstructs them with COLMAP and shows here what came back.</p>")
    out = f"<table>{_rows([(k.strip(), v.strip()) for k, v in sim.rows()])}</table>"
    if len(sim.draws) > 1:
        out += draws_html(sim)
    return out


def photos_section(check) -> str:
    """For ``coverplan check``: its verdict, and every photo not in the model with why.

    Parameters
    ----------
    check : Check
        ``coverplan check``'s result.

    Returns
    -------
    str
        HTML.
    """
    unused = [(n, "left out before SfM: " + w) for n, w in check.left_out] + list(check.lost)
    body = "".join(f"<tr><td class=l>{html.escape(n)}</td><td class=l>{html.escape(w)}</td></tr>" for n, w in unused)
    listed = (f"<h3>Photos not in the model ({len(unused)})</h3><table id=photos-lost><tr><th class=l>photo</th>"
              f"<th class=l>why</th></tr>{body}</table>") if unused else "<p>Every photo is in the model.</p>"
    return f"<table>{_rows([(k.strip(), v.strip()) for k, v in check.rows()])}</table>{listed}"


def draws_html(sim) -> str:
    """What each drawn flight lost: photos SfM could not place, surface without a 3D point, per class.

    Parameters
    ----------
    sim : Simulation
        A simulation with several drawn flights.

    Returns
    -------
    str
        HTML.
    """
    classes = sorted({c for d in sim.draws for c in d["by_class_pct"]})
    head = "".join(f"<th>{html.escape(c)}</th>" for c in classes)
    body = []
    for k, d in enumerate(sim.draws):
        label = f"seed {d['seed']}" + (" (worst: the verdict)" if k == sim.worst_draw else "")
        cells = "".join(f"<td>{100.0 - d['by_class_pct'].get(c, 100.0):.1f} %</td>" for c in classes)
        body.append(f"<tr><td class=l>{label}</td><td>{d['photos'] - d['registered']} of {d['photos']}</td>"
                    f"<td>{d['models']}</td><td>{100.0 - d['surface_0.2_pct']:.1f} %</td>{cells}"
                    f"<td>{'yes' if d['reconstructable'] else 'no'}</td></tr>")
    return (f"<h3>{len(sim.draws)} flights drawn under {html.escape(sim.conditions)} conditions: what each lost</h3>"
            f"<table><tr><th>draw</th><th>photos lost</th><th>models</th><th>surface missing @0.2 m</th>{head}"
            f"<th>reconstructable</th></tr>{''.join(body)}</table>")


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

