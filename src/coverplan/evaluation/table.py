"""The evaluation's metrics as the table ``coverplan evaluate`` prints."""

from __future__ import annotations

from coverplan.shots.sharpness import SHARP_INCIDENCE_DEG


def _fmt(v, unit="") -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:,.2f}{unit}"
    return f"{v}{unit}"


def _worst_class(pct: dict) -> str:
    if len(pct) < 2:
        return ""
    name = min(pct, key=pct.get)
    return f" (least: {name.replace('_', ' ')} {pct[name]:.1f} %)"


def format_metrics(m: dict) -> str:
    """A terminal table of the metrics.

    Parameters
    ----------
    m : dict
        ``Evaluation.metrics``.

    Returns
    -------
    str
        One line per metric, names aligned.
    """
    def stats(name, s, unit=""):
        return (name, f"min {_fmt(s['min'], unit)}  max {_fmt(s['max'], unit)}  mean {_fmt(s['mean'], unit)}")
    rows = [
        ("safe", "yes" if m["safe"] else "NO"),
        ("min clearance", f"{_fmt(m['min_clearance_m'], ' m')} (security {m['security_m']:.2f} m"
                          + (f", nearest {m['min_clearance_mesh']})" if m.get("min_clearance_mesh") else ")")),
        ("unsafe segments", str(m["unsafe_segment_count"])),
        ("waypoints inside meshes", str(m["waypoints_inside_meshes"])),
        ("altitude violations", f"{m['altitude_violations']} waypoints, "
                                f"{m.get('segments_below_min_altitude_count', 0)} segments (lowest "
                                f"{_fmt(m.get('lowest_above_ground_m'), ' m')} above "
                                f"{'the terrain' if m.get('terrain') else 'flat ground'}, minimum "
                                f"{_fmt(m.get('min_altitude_m'), ' m')})"),
        *([("ground clearance", f"{_fmt(m['ground_clearance_m'], ' m')} from the terrain in 3D, "
                                f"{m['segments_near_ground_count']} segments closer than the security distance")]
          if m.get("ground_clearance_m") is not None else []),
        *([("altitude ceiling", f"{_fmt(m['max_altitude_m'], ' m')} above the ground: highest "
                                f"{_fmt(m.get('highest_above_ground_m'), ' m')}, {m['above_ceiling_count']} "
                                "waypoints or segments above it")] if m.get("max_altitude_m") is not None else []),
        *([("zones", f"{len(m['zones'])} ({', '.join(z['kind'] + ' ' + z['name'] for z in m['zones'])}): "
                     f"{m['zone_breach_count']} waypoints or segments breach them; the flight keeps "
                     f"{_fmt(m['zone_distance_m'], ' m')} from them in plan view"
                     + (f", first {m['zone_breaches'][0]['zone']}" if m['zone_breach_count'] else ""))]
          if m.get("zones") else []),
        *([("flown through", f"{m['flown_through']['photos_in_passing']} photos in passing, taken at most "
                             f"{m['flown_through']['max_photo_offset_m']:.2f} m from the planned point; the cut "
                             f"corners keep {_fmt(m['flown_through']['min_clearance_m'], ' m')}"
                             + ("" if m["flown_through"]["safe"] else " (UNSAFE: closer than the security distance, "
                                "outside the altitude band or in a zone)"))]
          if m.get("flown_through") else []),
        ("orientation mismatches", str(m["orientation_mismatches"])),
        ("coverage of reachable", f"{m['coverage_pct']:.2f} % (checked every {m['sample_spacing_m']:.2f} m)"),
        (f"seen within {SHARP_INCIDENCE_DEG:g} deg", f"{m['sharp_view_pct']:.1f} % of the covered surface"
                               + _worst_class(m.get("sharp_view_by_class_pct", {}))),
        *([(f"framed by {m['framed_views_judged']} views", f"{m['framed_view_pct']:.1f} % of the covered surface "
             "(its face fills 25 % of the frame, or most of the best photo's, within 50 deg)")]
          if "framed_view_pct" in m else []),
        ("reachable surface", f"{m['reachable_area_m2']:,.1f} of {m['surface_area_m2']:,.1f} m2"),
        ("uncovered reachable", f"{m['uncovered_reachable_area_m2']:,.1f} m2 ({m['uncovered_reachable_samples']} samples)"),
        ("unreachable", f"{m['unreachable_area_m2']:,.1f} m2 ({m['unreachable_samples']} samples)"),
    ]
    for g in m["unreachable"][:5]:
        c = g["centroid"]
        rows.append(("  why", f"{g['reason']}: {g['count']} samples, {g['area_m2']:.1f} m2 "
                              f"around ({c[0]:.1f}, {c[1]:.1f}, {c[2]:.1f})"))
    for cause, a in m["left_out_area_m2"].items():
        rows.append((f"left out ({cause})", f"{a:,.1f} m2"))
    rows += [
        ("shots", str(m["shots"])),
        ("path length", _fmt(m["path_length_m"], " m")),
        stats("nt-imaged", m["nt_imaged"]),
        stats("d-image", m["d_image_m"], " m"),
        stats("db-viewpoints", m["db_viewpoints_m"], " m"),
        ("p-outliers", str(m["p_outliers"])),
        ("shots per m2", f"{m['shots_per_m2']:.4f}"),
        ("path m per m2", f"{m['path_m_per_m2']:.4f}"),
        ("samples", f"{m['samples']} at {m['sample_spacing_m']:.2f} m spacing"),
    ]
    g = m.get("shot_graph")
    if g:
        rows += [("matchable photo sets", f"{g['components']} (largest {g['largest_component']} of {g['shots']} photos)"),
                 ("photos short of neighbours", f"{g['shots_short_of_neighbours']} (fewer than {g['min_neighbours']} "
                                                f"sharing {100 * g['min_overlap']:.0f} % within {g['max_pair_deg']:g} deg)"),
                 ("photos the links hang on", f"{g.get('cut_shots', 0)} (each the only link between two groups)")]
    width = max(len(r[0]) for r in rows)
    return "\n".join(f"{name.ljust(width)}  {value}" for name, value in rows)
