"""The evaluator's metrics of a route: clearance, altitude band and zones along the flown path, GSD, orientation, coverage."""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass

import numpy as np

from coverplan.evaluation.ground import ground_clearance, heights_above_ground
from coverplan.evaluation.photos import photo_poses
from coverplan.evaluation.result import Evaluation
from coverplan.flight.corners import flown_path
from coverplan.flight.route import Route
from coverplan.shots.framing import FRAMED_VIEWS_JUDGED, frame_fill, framed_view_matrix, view_fill
from coverplan.shots.limits import ViewLimits
from coverplan.shots.sharpness import SHARP_INCIDENCE_DEG, best_incidence, incidence_deg
from coverplan.shots.surface import (
    CLASS_NAMES,
)
from coverplan.world.zones import Zones

ORIENTATION_TOLERANCE_DEG = 0.5


ALTITUDE_TOLERANCE_M = 1e-3  # route files keep 0.1 mm; a floor that follows terrain is rarely a round number


def _flown_through(route: Route, scene, limits: ViewLimits, zones: Zones) -> dict | None:
    """The corners a route flown through cuts (passing.py), judged as its segments are: the
    security distance, the altitude band and the zones; and how far its photos are taken from
    the planned points. None for a route that stops at every waypoint."""
    if not route.flies_through:
        return None
    passing = route.passing()
    path = flown_path(route.positions, np.where(passing, route.turn_damping, 0.0))
    d, _mesh, _exact = scene.clearance_model(route.security).polyline_clearance(path, route.security)
    tol = 1e-6 * max(1.0, route.security)
    band = _segment_band(path, scene, limits, zones, route.security)  # as the route's own segments
    outside = np.union1d(np.union1d(band.low, band.high), band.near_ground)
    offset = np.linalg.norm(route.flown_positions() - route.positions, axis=1)
    return {"waypoints_flown_through": int(passing.sum()), "photos_in_passing": int((passing & route.shot).sum()),
            "min_clearance_m": float(d.min()) if len(d) else None,
            "max_photo_offset_m": float(offset[route.shot].max()) if route.shot.any() else 0.0,
            "cut_corners_outside_band": int(len(outside)), "zone_breaches": len(band.zone_breaches),
            "safe": bool((d >= route.security - tol).all() and not len(outside) and not band.zone_breaches)}


@dataclass
class _Band:
    lowest: np.ndarray  # (n - 1,) each segment's least height above the ground
    highest: np.ndarray  # (n - 1,) and its greatest
    low: np.ndarray  # segments below the minimum altitude
    high: np.ndarray  # segments above the ceiling
    to_ground: float | None  # least 3D distance from the terrain (None: flat ground)
    near_ground: np.ndarray  # segments closer to the terrain than the security distance
    zone_breaches: list


def _segment_band(points, scene, limits: ViewLimits, zones: Zones, security: float) -> _Band:
    """Where the polyline leaves the altitude band, comes near the terrain or enters a zone,
    with the altitude tolerance the evaluator allows."""
    lowest, highest = heights_above_ground(points, limits)
    to_ground, near_ground = ground_clearance(points, scene, security)
    return _Band(lowest, highest, np.flatnonzero(lowest < limits.min_altitude - ALTITUDE_TOLERANCE_M),
                 np.flatnonzero(highest > limits.max_altitude + ALTITUDE_TOLERANCE_M), to_ground,
                 np.asarray(near_ground), _zone_breaches(points, zones))


def _zone_breaches(positions: np.ndarray, zones: Zones) -> list[dict]:
    """Every waypoint and segment in a keep-out zone or out of the keep-in region, exactly."""
    if not zones:
        return []
    at = zones.point_breaches(positions)
    out = [{"waypoint": int(k), "zone": zones.describe(at[k])} for k in np.flatnonzero(at >= 0)]
    if len(positions) > 1:
        along = zones.segment_breaches(positions[:-1], positions[1:])
        out += [{"segment": int(k), "from": int(k), "to": int(k + 1), "zone": zones.describe(along[k])}
                for k in np.flatnonzero(along >= 0)]
    return out


def _zone_distance(positions: np.ndarray, zones: Zones) -> float | None:
    """The flight's least plan-view distance to a keep-out zone or the keep-in boundary."""
    if not zones:
        return None
    ends = positions[1:] if len(positions) > 1 else positions
    return float(zones.plan_distance(positions[:len(ends)], ends).min())


def _stats(values) -> dict:
    values = np.asarray(values, dtype=float)
    if len(values) == 0:
        return {"min": None, "max": None, "mean": None}
    return {"min": float(values.min()), "max": float(values.max()), "mean": float(values.mean())}


def _gsd_achieved(ev: Evaluation) -> dict:
    """The finest GSD each covered sample is photographed at (its nearest valid view): median,
    95th percentile and coarsest, in m/px."""
    _, point, distance = ev.pairs
    best = np.full(len(ev.samples), np.inf)
    np.minimum.at(best, point, distance)
    best = best[ev.covered & ev.reachable & np.isfinite(best)]
    if not len(best):
        return {"median": None, "p95": None, "max": None}
    gsd = ev.route.camera.gsd_at(best)
    return {"median": float(np.median(gsd)), "p95": float(np.percentile(gsd, 95)), "max": float(gsd.max())}


def route_metrics(ev: Evaluation, scene, limits: ViewLimits) -> dict:
    """The evaluator's metrics of a route evaluated on its samples (``Evaluation.metrics``).

    Parameters
    ----------
    ev : Evaluation
        The evaluation so far: route, samples, coverage and clearance filled in.
    scene : Scene
        The scene.
    limits : ViewLimits
        The viewpoint rules the route is judged by.

    Returns
    -------
    dict
        Metric name to value: coverage, clearance, altitude, zones, GSD, orientation, photo set.
    """
    route, samples = ev.route, ev.samples
    area = samples.area
    reach = ev.reachable
    reachable_area = float(area[reach].sum())
    covered_area = float(area[ev.covered & reach].sum())
    shots = route.shots
    photos = photo_poses(route)
    shot_pos = photos[0]
    total_area = samples.total_area
    security = route.security
    tol = 1e-6 * max(1.0, security)
    unsafe = np.flatnonzero(ev.segment_clearance < security - tol)
    p = route.positions
    low = np.flatnonzero(~limits.above_floor(p, ALTITUDE_TOLERANCE_M))
    zones = Zones.from_list(route.params.get("zones"))
    band = _segment_band(p, scene, limits, zones, security)
    lowest, highest, low_segments, high_segments = band.lowest, band.highest, band.low, band.high
    to_ground, near_ground, zone_breaches = band.to_ground, band.near_ground, band.zone_breaches
    high = np.flatnonzero(~limits.below_ceiling(p, ALTITUDE_TOLERANCE_M))
    orient = route.orientation_errors_deg()
    through = _flown_through(route, scene, limits, zones)
    seg_k = int(np.argmin(ev.segment_clearance)) if len(ev.segment_clearance) else None
    p_outliers = (ev.views >= 2) & (ev.widest_deg < float(route.param("min_triangulation_deg")))

    unreachable = defaultdict(lambda: {"count": 0, "area_m2": 0.0, "points": []})
    for k in np.flatnonzero(~reach):
        g = unreachable[ev.reasons[k]]
        g["count"] += 1
        g["area_m2"] += float(area[k])
        g["points"].append(samples.points[k])
    unreachable_groups = []
    for reason, g in sorted(unreachable.items(), key=lambda kv: -kv[1]["area_m2"]):
        pts = np.array(g["points"])
        unreachable_groups.append({"reason": reason, "count": g["count"], "area_m2": g["area_m2"],
                                   "centroid": pts.mean(axis=0).tolist(),
                                   "bounds": [pts.min(axis=0).tolist(), pts.max(axis=0).tolist()]})
    missed = reach & ~ev.covered
    # Sharp views (reconstructability.py): what SfM rebuilds depends on how squarely the
    # best photo sees the surface, so it is reported beside the view count.
    cam, pt, _rng = ev.pairs
    inc = incidence_deg(cam, pt, shot_pos, samples.points, samples.normals)
    best = best_incidence(pt, inc, len(samples))
    sharp = ev.covered & reach & (best <= SHARP_INCIDENCE_DEG)
    # Framed views (framing.py): judged against the best the route's own photos give where no
    # photo fills 25 %, so this is the rule as the flight meets it, not what any viewpoint could.
    fill = view_fill(frame_fill(scene, *photos, route.camera), cam, pt, samples.normals)
    framed_n = np.asarray(framed_view_matrix(cam, pt, fill, inc, len(shot_pos), len(samples)).sum(axis=0)).ravel()
    framed_want = int(route.params.get("framed_views") or FRAMED_VIEWS_JUDGED)
    framed = ev.covered & reach & (framed_n >= framed_want)
    by_class, sharp_by_class = {}, {}
    for k, name in enumerate(CLASS_NAMES):
        sel = (samples.kind == k) & reach
        if sel.any():
            by_class[name] = 100.0 * float(area[sel & ev.covered].sum()) / float(area[sel].sum())
        if (sel & ev.covered).any():
            sharp_by_class[name] = 100.0 * float(area[sel & sharp].sum()) / float(area[sel & ev.covered].sum())
    worst_where = None
    if seg_k is not None and len(route.positions) > 1:
        worst_where = scene.clearance_model(route.security).closest_point_on_segment(route.positions[seg_k],
                                                               route.positions[seg_k + 1])[0].tolist()
    return {
        "shots": int(len(shots)),
        "waypoints": int(len(route)),
        "path_length_m": route.path_length,
        "surface_area_m2": total_area,
        "reachable_area_m2": reachable_area,
        "covered_area_m2": covered_area,
        "coverage_pct": 100.0 * covered_area / reachable_area if reachable_area > 0 else 0.0,
        "coverage_by_class_pct": by_class,
        "sharp_view_pct": 100.0 * float(area[sharp].sum()) / covered_area if covered_area > 0 else 0.0,
        "sharp_view_by_class_pct": sharp_by_class,
        "framed_views_judged": framed_want,
        "framed_view_pct": 100.0 * float(area[framed].sum()) / covered_area if covered_area > 0 else 0.0,
        "best_incidence_deg": _stats(best[ev.covered & reach]),
        "uncovered_reachable_area_m2": float(area[missed].sum()),
        "uncovered_reachable_samples": int(missed.sum()),
        "unreachable_area_m2": float(area[~reach].sum()),
        "unreachable_samples": int((~reach).sum()),
        "unreachable": unreachable_groups,
        "left_out_area_m2": dict(samples.left_out),
        "samples": int(len(samples)),
        "sample_spacing_m": samples.spacing,
        "nt_imaged": _stats(ev.views[reach]),
        "d_image_m": _stats(ev.pairs[2]),
        "gsd_achieved_m": _gsd_achieved(ev),
        "db_viewpoints_m": _stats(np.linalg.norm(np.diff(shot_pos, axis=0), axis=1)),
        "p_outliers": int(p_outliers.sum()),
        "shots_per_m2": len(shots) / total_area,
        "path_m_per_m2": route.path_length / total_area,
        "min_clearance_m": float(ev.segment_clearance.min()) if len(ev.segment_clearance) else None,
        "min_clearance_at": worst_where,
        "min_clearance_mesh": scene.describe(int(ev.segment_mesh[seg_k])) if seg_k is not None and ev.segment_mesh[seg_k] >= 0 else None,
        "unsafe_segments": [{"segment": int(k), "from": int(k), "to": int(k + 1),
                             "clearance_m": float(ev.segment_clearance[k]),
                             "mesh": scene.describe(int(ev.segment_mesh[k])) if ev.segment_mesh[k] >= 0 else None}
                            for k in unsafe[:50]],
        "unsafe_segment_count": int(len(unsafe)),
        "waypoints_inside_meshes": int(ev.waypoint_inside.sum()),
        "altitude_violations": int(len(low)),
        "segments_below_min_altitude": [{"segment": int(k), "lowest_above_ground_m": float(lowest[k])}
                                        for k in low_segments[:50]],
        "segments_below_min_altitude_count": int(len(low_segments)),
        "lowest_above_ground_m": float(lowest.min()) if len(lowest) else float(p[0, 2] - limits.ground_at(p[:1, :2])[0]),
        "min_altitude_m": limits.min_altitude,
        "ground_clearance_m": to_ground,  # the flight's least distance from the terrain in 3D (None: flat)
        "segments_near_ground_count": int(len(near_ground)),
        "max_altitude_m": limits.max_altitude if np.isfinite(limits.max_altitude) else None,
        "highest_above_ground_m": float(highest.max()) if len(highest) else
        float(p[0, 2] - limits.ground_at(p[:1, :2])[0]),
        "above_ceiling_count": int(len(high) + len(high_segments)),
        "zones": [{"name": z.name, "kind": z.kind} for z in zones.zones],
        "zone_margin_m": float(route.params.get("zone_margin_m") or 0.0) if zones else None,
        "zone_breaches": zone_breaches[:50],
        "zone_breach_count": len(zone_breaches),
        "zone_distance_m": _zone_distance(p, zones),
        "min_altitude_z_m": limits.min_z,
        "terrain": scene.terrain.source if scene.terrain is not None else None,
        "orientation_mismatches": int((orient > ORIENTATION_TOLERANCE_DEG).sum()),
        "returns_to_start": bool(np.linalg.norm(route.positions[-1] - route.positions[0]) < 1e-6),
        "flown_through": through,
        "safe": bool(len(unsafe) == 0 and len(low) == 0 and len(low_segments) == 0 and not ev.waypoint_inside.any()
                     and len(near_ground) == 0 and len(high) == 0 and len(high_segments) == 0
                     and len(zone_breaches) == 0 and (through is None or through["safe"])),
        "security_m": security,
        "d_opt_m": route.d_opt,
    }
