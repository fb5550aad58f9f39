"""The plan summary ``coverplan plan`` prints: a pilot's figures first, the planner's under ``-v``."""

from __future__ import annotations

from coverplan.report.takeoff import takeoff_point, takeoff_text


def plan_summary(route, verbose: bool = False) -> str:
    """The summary ``plan`` prints: what a pilot needs first, in plain words and rounded figures;
    ``verbose``: the planner's internals after it.

    Parameters
    ----------
    route : Route
        The planned route.
    verbose : bool
        Add the planner's internals.

    Returns
    -------
    str
        The summary.
    """
    rows = pilot_rows(route)
    if verbose:
        rows += [("", ""), ("planner", "")] + internal_rows(route)
    width = max(len(r[0]) for r in rows)
    return "\n".join(f"{a.ljust(width)}  {b}".rstrip() for a, b in rows)


def pilot_rows(route) -> list[tuple[str, str]]:
    """Photos, flights and minutes, path, GSD, heights, take-off, coverage, clearance, what is missing.

    Parameters
    ----------
    route : Route
        The planned route.

    Returns
    -------
    list of (str, str)
        Label and value.
    """
    m = route.metrics
    ev = m.get("evaluation") or {}
    flights = m.get("flights") or []
    rows = [("photos", f"{m['shots']}" + (f", {len(flights)} battery flights" if len(flights) > 1 else ""))]
    if m.get("existing"):
        rows.append(("existing photos", f"{m['existing']['photos']} ({route.params['existing_photos']['source']}) "
                                        f"count toward the rules; alone they cover {m['existing']['coverage_pct']:.1f} "
                                        f"% of the reachable surface; this flight adds {m['shots']} photos"))
    rows += _minutes_rows(route)
    rows.append(("path", f"{route.path_length:,.0f} m"))
    rows.append(("GSD", _gsd_text(route, ev)))
    above = route.above_ground()
    ceiling = route.params.get("max_altitude_m")
    rows.append(("height above ground", f"{above.min():.1f} to {above.max():.1f} m"
                                        + (f" (ceiling {ceiling:g} m)" if ceiling else " (no ceiling)")))
    point = takeoff_point(route)
    rows.append(("take-off", takeoff_text(point)))
    if point["map"]:
        rows.append(("  on the map", point["map"]))
    if ev:
        rows.append(("coverage", f"{ev['coverage_pct']:.1f} % of the reachable surface (checked on fresh samples "
                                 f"every {ev['sample_spacing_m']:.2f} m)"))
        where = f" from {ev['min_clearance_mesh']}" if ev.get("min_clearance_mesh") else ""
        rows.append(("closest approach", f"{ev['min_clearance_m']:.1f} m{where} (security distance "
                                         f"{route.security:g} m)" + ("" if ev["safe"] else "  UNSAFE")))
        if ev.get("shot_graph"):
            rows.append(photo_sets_row(ev["shot_graph"]))
    else:
        rows.append(("coverage", f"{m['planned_coverage_pct']:.1f} % of the reachable surface, as planned (not "
                                 "evaluated: --no-evaluate)"))
    if route.params.get("zones"):
        rows.append(("zones", ", ".join(f"{z['kind']} {z['name']}" for z in route.params["zones"])
                              + f"; kept {route.params.get('zone_margin_m', 0.0):g} m clear of them"))
    reasons: dict[str, float] = {}
    for u in route.uncovered:
        reasons[u["reason"]] = reasons.get(u["reason"], 0.0) + u.get("area_m2", 0.0)
    for reason, area in sorted(reasons.items(), key=lambda kv: -kv[1])[:5]:
        rows.append(("  not covered", f"{area:.1f} m2: {reason}"))
    for note in summarize_notes([n for n in route.extra.get("notes", []) if n.startswith("WARNING")]):
        rows.append(("  note", note))
    return rows


def _gsd_text(route, ev: dict) -> str:
    asked = f"{route.gsd * 1000:.1f} mm/px asked"
    gsd = ev.get("gsd_achieved_m") or {}
    if gsd.get("median") is None:
        return asked
    return (f"{asked}; achieved {gsd['median'] * 1000:.1f} mm/px (median over the surface), "
            f"{gsd['max'] * 1000:.1f} mm/px at the coarsest point")


def _minutes_rows(route) -> list[tuple[str, str]]:
    """Each battery flight's minutes, flown through (as the WPML and QGC exports fly) and stopping."""
    m = route.metrics
    flights = m.get("flights") or []
    through = m.get("fly_through") if route.flies_through else None
    stopping = sum(f["minutes"] for f in flights)
    if through:
        text = f"{through['minutes']:.1f} min flown through ({stopping:.1f} min stopping at every photo)"
    else:
        text = f"{stopping:.1f} min, stopping at every photo"
    rows = [("flight time", text + _limits(route))]
    if len(flights) > 1:
        passing = (through or {}).get("flight_minutes") or [None] * len(flights)
        for f, flown in zip(flights, passing):
            share = f["limit_share_pct"]
            minutes = f"{f['minutes']:.1f} min" if flown is None else f"{flown:.1f} min flown through"
            rows.append((f"  flight {f['flight']}", f"{f['shots']} photos, {minutes}, {f['path_m']:,.0f} m"
                                                   + ("" if share is None else
                                                      f" ({share:.0f} % of the time limit, stopping)")))
    return rows


def _limits(route) -> str:
    """The split's limits, as the summary states them."""
    limit = route.params.get("max_flight_min")
    items = route.params.get("max_mission_items")
    limits = ([f"{limit:g} min"] if limit else []) + ([f"{items} mission items"] if items else [])
    return f"; limit {' and '.join(limits)} per flight" if limits else ""


def internal_rows(route) -> list[tuple[str, str]]:
    """The planner's figures (``plan -v``): LP bound, edge views, model, tour, sampling, timings.

    Parameters
    ----------
    route : Route
        The planned route.

    Returns
    -------
    list of (str, str)
        Label and value.
    """
    m = route.metrics
    rows = []
    if m.get("lp_lower_bound_shots"):
        rows.append(("LP lower bound", f"{m['lp_lower_bound_shots']:.1f} photos"))
    if route.params.get("edge_views"):
        rows.append(("edge views", f"{m['edge_view_shots']} of the shots look at a corner or an eave from the "
                                   "bisector of its two faces, so SfM joins each face to the next (--edge-views off "
                                   "leaves them out)"))
    rows.append(("orbit", f"{m['orbit_length_m']:,.1f} m (one orbit at the standoff, for comparison)"))
    rows += _flight_rows(route)
    rows.append(("coverage (planned)", f"{m['planned_coverage_pct']:.2f} % of the reachable surface"
                                       + (f", checked every {m['check_spacing_m']:.2f} m"
                                          if m.get("check_spacing_m") else "")))
    ev = m.get("evaluation")
    if ev:
        rows.append(("coverage (evaluated)", f"{ev['coverage_pct']:.2f} %, p-outliers {ev['p_outliers']}"
                                             + (", with the existing photos" if m.get("existing") else "")))
    rows.append(("uncovered samples", f"{len(route.uncovered)}"))
    rows.append(("d_opt / standoff", f"{m['d_opt_m']:.2f} m / {m['standoff_m']:.2f} m"))
    rows.append(("ground", f"terrain {route.params['terrain']}; minimum altitude "
                           f"{route.params.get('min_altitude_m', route.security):g} m above it along every segment, "
                           "the security distance from it in 3D"
                           if route.params.get("terrain") else
                           f"flat at z {route.takeoff_z:.2f} (no terrain given: --terrain DTM.tif)"))
    rows.append(("planning time", f"{m['planning_time_s']:.2f} s"))
    for note in summarize_notes([n for n in route.extra.get("notes", []) if not n.startswith("WARNING")]):
        rows.append(("  note", note))
    return rows


def photo_sets_row(graph: dict) -> tuple[str, str]:
    """The summary's row for the evaluator's sets of linked photos (``evaluation.shot_graph``):
    more than one set is said loudly, since SfM then tends to return a model per set (the
    triangle prism's 51-photo ``--link-test samples`` plan, in four sets: 16-25 of 51 photos in
    the largest of 3-4 models in three field draws, docs/reconstruction.md).

    Parameters
    ----------
    graph : dict
        ``evaluation.shot_graph``'s summary.

    Returns
    -------
    (str, str)
        Label and value.
    """
    sets, largest, shots = graph["components"], graph["largest_component"], graph["shots"]
    if sets <= 1:
        text = f"1: every photo linked to the others ({graph['link_test']} link test, fresh samples)"
    else:
        text = (f"{sets} (largest {largest} of {shots} photos)  WARNING: SfM is likely to return several models; "
                "run coverplan simulate before flying")
    return ("photo sets", text)


def _ground(route):
    """The ground under each waypoint: the terrain's, recorded in the route, or flat."""
    return route.ground_z if route.ground_z is not None else route.params.get("ground_z_m", 0.0)


def _flight_rows(route) -> list[tuple[str, str]]:
    """How the flight time is modelled (docs/flights.md), photos in passing and the tour's shape."""
    m = route.metrics
    flights = m.get("flights") or []
    model = m.get("flight_model") or {}
    total = sum(f["minutes"] for f in flights)
    drone = route.params.get("drone")
    stops = "every photo and corner" if route.straight_points().any() else "every waypoint"
    how = f"{model.get('cruise_speed', 0):g} m/s, stops at {stops}" + (f", {drone}" if drone else "")
    rows = [("flight-time model", f"{total:.1f} min stopping ({how})")]
    through = m.get("fly_through")
    if through and route.flies_through:
        rows.append(("flown through", f"{through['minutes']:.1f} min: {through['photos_in_passing']} of "
                                      f"{through['photos']} photos taken in passing (at most "
                                      f"{through['fastest_photo_mps']:.1f} m/s, {through['max_photo_offset_m']:.2f} m "
                                      "off the planned point), stops elsewhere; the WPML and QGroundControl "
                                      "exports fly it so, Litchi stops at every waypoint"))
    if "smooth_steps_pct" in m:
        rows.append(("flight shape", f"{m['smooth_steps_pct']:.0f} % smooth steps (heading within 10 deg, pitch "
                                     f"within 5 deg), {m['reversals_per_100']:.0f} reversals per 100 photos; "
                                     f"view tilts {route.params.get('view_tilts', 'varied')}, a reversal costs the tour "
                                     f"{route.params.get('reversal_m', 0.0):.1f} m "
                                     f"({route.params.get('reversal_steps', 0.0):g} steps), a step that turns the "
                                     f"camera {route.params.get('reaim_m', 0.0):.1f} m "
                                     f"({route.params.get('reaim_steps', 0.0):g} steps)"))
    if len(flights) > 1:
        extra = route.path_length / m["single_flight_path_m"] if m.get("single_flight_path_m") else float("nan")
        rows.append(("flights", f"{len(flights)}, each from the start point back to it; path {extra:.2f}x one "
                                "single flight's"))
    return rows


def summarize_notes(notes: list[str], limit: int = 10) -> list[str]:
    """Notes that repeat with another mesh's name or another count are told once, with a tally.

    Parameters
    ----------
    notes : list of str
        The notes.
    limit : int
        The most told.

    Returns
    -------
    list of str
        The notes, each once.
    """
    import re
    groups: dict[str, list[str]] = {}
    for note in notes:
        key = re.sub(r"\d+", "N", note.split(": ", 1)[-1]) if ": " in note else note
        groups.setdefault(key, []).append(note)
    out = []
    for key, items in groups.items():
        out.append(items[0] if len(items) == 1 else f"{key.replace('N', 'some')} ({len(items)} meshes)")
    return out[:limit] + ([f"... and {len(out) - limit} more"] if len(out) > limit else [])
