"""The report's tables and sections, as HTML: headline, metrics, flights, road map, what is uncovered, what SfM recovered and the photos check could not use."""

from __future__ import annotations

import html

from coverplan.equipment.flighttime import FlightModel
from coverplan.flight.battery import flight_table
from coverplan.report.plan_view import flight_colour
from coverplan.report.takeoff import takeoff_point, takeoff_text


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
