"""The plan summary ``coverplan plan`` prints: shots, path, flights, coverage, notes."""

from __future__ import annotations


def plan_summary(route) -> str:
    m = route.metrics
    rows = [
        ("shots", f"{m['shots']}" + (f"  (LP lower bound {m['lp_lower_bound_shots']:.1f})"
                                      if m.get("lp_lower_bound_shots") else "")),
        *([("existing photos", f"{m['existing']['photos']} ({route.params['existing_photos']['source']}) count "
                               f"toward the rules; alone they cover {m['existing']['coverage_pct']:.1f} % of the "
                               f"reachable surface; this flight adds {m['shots']} shots")] if m.get("existing") else []),
        *([("edge views", f"{m['edge_view_shots']} of the shots look at a corner or an eave from the bisector of its "
                          f"two faces, so SfM joins each face to the next (--edge-views off leaves them out)")]
          if route.params.get("edge_views") else []),
        ("path length", f"{route.path_length:,.1f} m  (one orbit at the standoff: {m['orbit_length_m']:,.1f} m)"),
        *_flight_rows(route),
        ("coverage (planned)", f"{m['planned_coverage_pct']:.2f} % of the reachable surface"
                               + (f", checked every {m['check_spacing_m']:.2f} m" if m.get("check_spacing_m") else "")),
        ("uncovered samples", f"{len(route.uncovered)}"),
        ("d_opt / standoff", f"{m['d_opt_m']:.2f} m / {m['standoff_m']:.2f} m"),
        ("ground", f"terrain {route.params['terrain']}; minimum altitude "
                   f"{route.params.get('min_altitude_m', route.security):g} m above it along every segment, the "
                   f"security distance from it in 3D"
                   if route.params.get("terrain") else
                   f"flat at z {route.takeoff_z:.2f} (no terrain given: --terrain DTM.tif)"),
        ("ceiling", f"{route.params['max_altitude_m']:g} m above the ground (highest "
                    f"{float((route.positions[:, 2] - _ground(route)).max()):.1f} m)"
                    if route.params.get("max_altitude_m") else "none"),
        *([("zones", ", ".join(f"{z['kind']} {z['name']}" for z in route.params["zones"])
                     + f"; kept {route.params.get('zone_margin_m', 0.0):g} m clear of them")]
          if route.params.get("zones") else []),
        ("planning time", f"{m['planning_time_s']:.2f} s"),
    ]
    ev = m.get("evaluation")
    if ev:
        at = next(k for k, r in enumerate(rows) if r[0] == "uncovered samples")
        rows.insert(at, ("coverage (evaluated)", f"{ev['coverage_pct']:.2f} % on fresh samples every "
                                                 f"{ev['sample_spacing_m']:.2f} m, p-outliers {ev['p_outliers']}"
                                                 + (", with the existing photos" if m.get("existing") else "")))
        rows.insert(at + 1, ("min clearance", f"{ev['min_clearance_m']:.2f} m (security {route.security:g} m)"
                                              + ("" if ev["safe"] else "  UNSAFE")))
        if ev.get("shot_graph"):
            rows.insert(at + 2, photo_sets_row(ev["shot_graph"]))
    reasons: dict[str, float] = {}
    for u in route.uncovered:
        reasons[u["reason"]] = reasons.get(u["reason"], 0.0) + u.get("area_m2", 0.0)
    for reason, area in sorted(reasons.items(), key=lambda kv: -kv[1])[:5]:
        rows.append(("  not covered", f"{area:.1f} m2: {reason}"))
    for note in summarize_notes(route.extra.get("notes", [])):
        rows.append(("  note", note))
    width = max(len(r[0]) for r in rows)
    return "\n".join(f"{a.ljust(width)}  {b}" for a, b in rows)


def photo_sets_row(graph: dict) -> tuple[str, str]:
    """The summary's row for the evaluator's sets of linked photos (``evaluation.shot_graph``):
    more than one set is said loudly, since SfM then tends to return a model per set (the
    triangle prism's 51-photo ``--link-test samples`` plan, in four sets: 16-25 of 51 photos in
    the largest of 3-4 models in three field draws, docs/reconstruction.md)."""
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
    """Flight time by the model (docs/flights.md), per battery flight when there are several."""
    m = route.metrics
    flights = m.get("flights") or []
    model = m.get("flight_model") or {}
    total = sum(f["minutes"] for f in flights)
    drone = route.params.get("drone")
    stops = "every photo and corner" if route.straight_points().any() else "every waypoint"
    how = f"{model.get('cruise_speed', 0):g} m/s, stops at {stops}" + (f", {drone}" if drone else "")
    limit = route.params.get("max_flight_min")
    items = route.params.get("max_mission_items")
    limits = ([f"{limit:g} min"] if limit else []) + ([f"{items} mission items"] if items else [])
    rows = [("flight time", f"{total:.1f} min by the flight-time model ({how})"
             + (f"; limit {' and '.join(limits)} per flight" if limits else ""))]
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
        for f in flights:
            share = f['limit_share_pct']
            rows.append((f"  flight {f['flight']}", f"{f['minutes']:.1f} min, {f['shots']} shots, {f['path_m']:,.0f} m"
                                                   + ("" if share is None else f", {share:.0f} % of the time limit")))
    return rows


def summarize_notes(notes: list[str], limit: int = 10) -> list[str]:
    """Notes that repeat with another mesh's name or another count are told once, with a tally."""
    import re
    groups: dict[str, list[str]] = {}
    for note in notes:
        key = re.sub(r"\d+", "N", note.split(": ", 1)[-1]) if ": " in note else note
        groups.setdefault(key, []).append(note)
    out = []
    for key, items in groups.items():
        out.append(items[0] if len(items) == 1 else f"{key.replace('N', 'some')} ({len(items)} meshes)")
    return out[:limit] + ([f"... and {len(out) - limit} more"] if len(out) > limit else [])
