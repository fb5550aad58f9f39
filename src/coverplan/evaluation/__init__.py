"""The measuring instrument: does this route cover this building, safely?

Everything here is recomputed from the route file and the scene (its own surface samples,
ray casts and FCL distance queries); nothing is read from the planner's bookkeeping.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field

import numpy as np

from coverplan.errors import ParameterError
from coverplan.evaluation.ground import ground_clearance, heights_above_ground
from coverplan.evaluation.table import format_metrics
from coverplan.flight.corners import flown_path
from coverplan.flight.route import Route
from coverplan.shots.framing import FRAMED_VIEWS_JUDGED, frame_fill, framed_view_matrix, view_fill
from coverplan.shots.limits import ViewLimits, scene_limits
from coverplan.shots.link_graph import graph_summary
from coverplan.shots.reachability import reachability
from coverplan.shots.reconstructability import MatchRule, shot_links
from coverplan.shots.sharpness import SHARP_INCIDENCE_DEG, best_incidence, incidence_deg
from coverplan.shots.surface import (
    CLASS_NAMES,
    SurfaceSamples,
    check_spacing,
    sample_surface,
)
from coverplan.shots.visibility import imaging_pairs, pair_stats, view_rays
from coverplan.world.zones import Zones

ORIENTATION_TOLERANCE_DEG = 0.5
ALTITUDE_TOLERANCE_M = 1e-3  # route files keep 0.1 mm; a floor that follows terrain is rarely a round number


RULES = ("strict", "thesis")


def view_limits(route: Route, scene, rule: str = "strict") -> ViewLimits:
    """The viewpoint rules a route declares in its params, in the scene's frame. Under the
    thesis's rule a point only has to face the camera (incidence < 90 deg).

    Parameters
    ----------
    route : Route
        The route whose params give the security distance, d_opt and incidence limit.
    scene : Scene
        The scene judged.
    rule : {"strict", "thesis"}
        ``"thesis"`` keeps only the facing condition.

    Returns
    -------
    ViewLimits
        The rules a view must meet.
    """
    ground = route.params.get("ground_z_m", scene.ground_z)
    min_alt = route.params.get("min_altitude_m", route.security)
    lo, hi = route.params.get("gimbal_pitch_range_deg", (-90.0, 90.0))
    incidence = float(route.param("max_incidence_deg")) if rule == "strict" else 89.9
    ceiling = route.params.get("max_altitude_m")
    # Reach is judged with the margin the planner kept from the zones; breaches (_metrics) exactly.
    zones = Zones.from_list(route.params.get("zones")).grown(float(route.params.get("zone_margin_m") or 0.0))
    if scene.terrain is not None:
        return scene_limits(scene, security=route.security, d_opt=route.d_opt, max_incidence_deg=incidence,
                            min_altitude=float(min_alt), pitch_range_deg=(lo, hi), vfov_deg=route.camera.vfov_deg,
                            max_altitude=ceiling, zones=zones)
    return ViewLimits(security=route.security, d_opt=route.d_opt,
                      max_incidence_deg=incidence,
                      min_z=float(ground) + float(min_alt), pitch_range_deg=(float(lo), float(hi)),
                      vfov_deg=route.camera.vfov_deg, ground_z=float(ground),
                      max_altitude=np.inf if ceiling is None else float(ceiling), zones=zones)


@dataclass
class Evaluation:
    """Per-sample results and the metrics of docs/design.md for one route.

    Parameters
    ----------
    route : Route
        The route judged.
    samples : SurfaceSamples
        The evaluator's own surface samples (n of them), never the planner's.
    views : (n,) int
        Valid views of each sample.
    widest_deg : (n,) float
        The widest angle between two of its valid views.
    covered, reachable : (n,) bool
        Covered by the rule; imageable from some safe position at all.
    reasons : list of str
        Why each unreachable sample cannot be imaged.
    pairs : tuple of three (m,) arrays
        Photo index, sample index and range (m) of every valid view.
    segment_clearance : (n_waypoints - 1,) float
        Each path segment's least distance to any mesh or the ground (m).
    segment_mesh : (n_waypoints - 1,) int
        The mesh that distance is to.
    waypoint_inside : (n_waypoints,) int
        The mesh a waypoint lies inside, -1 for none.
    metrics : dict
        Coverage, clearance, altitudes, zones, links, per class (``table()`` prints them).
    """

    route: Route
    samples: SurfaceSamples
    views: np.ndarray
    widest_deg: np.ndarray
    covered: np.ndarray
    reachable: np.ndarray
    reasons: list
    pairs: tuple
    segment_clearance: np.ndarray
    segment_mesh: np.ndarray
    waypoint_inside: np.ndarray
    metrics: dict = field(default_factory=dict)

    @property
    def safe(self) -> bool:
        """True when no part of the flight comes closer than the security distance to anything."""
        return bool(self.metrics["safe"])

    @property
    def coverage_pct(self) -> float:
        """The share of the target surface covered, in percent."""
        return float(self.metrics["coverage_pct"])

    def table(self) -> str:
        return format_metrics(self.metrics)


EVALUATOR_SEED = 7_368_787  # not the planner's: the check uses points the planner never saw


def evaluate(route: Route, scene, spacing: float | None = None, samples: SurfaceSamples | None = None,
             progress=None, rule: str = "strict", classes=None, seed: int = EVALUATOR_SEED) -> Evaluation:
    """Judge a route against a scene, on samples of its own, drawn with a seed the planner
    does not use.

    Parameters
    ----------
    route : Route
    scene : Scene
        The scene the route is flown in (its terrain too when the route was planned over one).
    spacing : float, optional
        Sample spacing in metres; None: every 0.25 m (``surface.check_spacing``).
    samples : SurfaceSamples, optional
        Judge on these samples instead of drawing new ones.
    progress : Progress, optional
    rule : {"strict", "thesis"}
        "strict" is docs/design.md's imaging rule; "thesis" the thesis's: in the frustum, in sight
        and facing the camera, at any range (GSD not checked).
    classes : sequence of str, optional
        Judge only these of facade / roof / terrace / opposed_terrace; None: the classes the
        route was planned for (all when it does not say).
    seed : int
        The samples' seed (the planner never uses the default).

    Returns
    -------
    Evaluation
        ``covered`` / ``reachable`` : (n,) bool per sample, ``metrics`` (coverage, clearance,
        links, per class), ``safe``.

    Raises
    ------
    ParameterError
        An unknown rule, or a route planned over terrain judged without it.

    Examples
    --------
    >>> import coverplan
    >>> scene = coverplan.load_scene("meshes/square_prism.obj")
    >>> route = coverplan.plan(scene, coverplan.get_camera("phantom4pro"), gsd=0.004, security=3.0)
    >>> ev = coverplan.evaluate(route, scene)
    >>> ev.safe, ev.coverage_pct > 99.0, ev.metrics["min_clearance_m"] >= 3.0
    (True, True, True)
    """
    if rule not in RULES:
        raise ParameterError(f"rule must be one of {RULES}, got {rule!r}")
    if route.params.get("terrain") and scene.terrain is None:
        raise ParameterError(f"the route was planned over the terrain {route.params['terrain']}: give it with "
                             "--terrain, its altitudes are judged against it")
    limits = view_limits(route, scene, rule)
    if samples is None:
        samples = sample_surface(scene, check_spacing(scene, spacing), seed=seed)
    classes = route.params.get("surface_classes") if classes is None else classes
    if classes:
        samples = samples.of_classes(classes)
    shots = route.shots
    photo_pos, photo_heading, photo_pitch = photo_poses(route)
    reach_range = route.d_opt if rule == "strict" else 4.0 * scene.extent + route.d_opt
    pairs = imaging_pairs(photo_pos, photo_heading, photo_pitch,
                          route.camera, samples.points, samples.normals, scene.rays,
                          max_range=reach_range, max_incidence_deg=limits.max_incidence_deg,
                          offset=scene.epsilon * 4, progress=progress)
    cam, pt, rng = pairs
    n = len(samples)
    views = np.bincount(pt, minlength=n)
    rays = view_rays(cam, pt, photo_pos, samples.points)
    min_views = int(route.param("min_views"))
    min_triangulation_deg = float(route.param("min_triangulation_deg"))
    max_pair_deg = route.params.get("max_pair_deg")
    widest, paired = pair_stats(pt, rays, n, min_triangulation_deg, max_pair_deg)
    covered = (views >= min_views) & paired

    # Safety along the whole polyline: exact FCL distances per segment, inside tests per waypoint.
    positions = route.positions
    clearance = scene.clearance_model(route.security)
    inside = scene.rays.inside(positions) >= 0
    if len(positions) > 1:
        seg_d, seg_mesh, _exact = clearance.polyline_clearance(positions, route.security)
    else:
        seg_d, seg_mesh = clearance.point_distance(positions)
    seg_d = seg_d.copy()
    for k in np.flatnonzero(inside):  # a waypoint inside a mesh has no clearance at all
        seg_d[max(k - 1, 0)] = 0.0
        seg_d[min(k, len(seg_d) - 1)] = 0.0
    # A shot the route flies safely proves the samples it images (under docs/design.md's rule) reachable.
    last = len(seg_d) - 1
    near = np.minimum(seg_d[np.clip(shots - 1, 0, last)], seg_d[np.clip(shots, 0, last)])
    shot_safe = (near >= route.security) & ~inside[shots] & limits.above_floor(positions[shots])
    shot_safe = np.concatenate([shot_safe, np.zeros(len(photo_pos) - len(shots), dtype=bool)])  # taken, not flown
    witness = shot_safe[cam] & (rng <= route.d_opt) & (rule == "strict")
    # Probing is the slow part: only samples no safe shot images need it.
    reach = reachability(scene, samples, limits, known=np.bincount(pt[witness], minlength=n) > 0)
    ev = Evaluation(route, samples, views, widest, covered, reach.reachable, reach.reason, pairs,
                    seg_d, seg_mesh, inside)
    ev.metrics = _metrics(ev, scene, limits)
    ev.metrics["rule"] = rule
    ev.metrics["shot_graph"] = shot_graph(route, samples, pairs)
    return ev


def photo_poses(route: Route) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions (k, 3), headings and pitches (k,) of every photo the route's coverage counts:
    its own, where the drone takes them (flown through, off the planned point), then the photos
    already taken that it was planned around (``params.existing_photos``).

    Parameters
    ----------
    route : Route
        The route judged.

    Returns
    -------
    positions : (k, 3) float
        Camera centres in the local frame, metres.
    headings, pitches : (k,) float
        Degrees (heading clockwise from north, pitch negative down).
    """
    rows = route.shots
    pos, heading, pitch = route.flown_positions()[rows], route.heading_deg[rows], route.pitch_deg[rows]
    taken = route.params.get("existing_photos") or {}
    if taken.get("positions"):
        pos = np.vstack([pos, np.asarray(taken["positions"], dtype=float).reshape(-1, 3)])
        heading = np.concatenate([heading, np.asarray(taken["heading_deg"], dtype=float)])
        pitch = np.concatenate([pitch, np.asarray(taken["pitch_deg"], dtype=float)])
    return pos, heading, pitch


def match_rule(route: Route) -> MatchRule:
    """The rule for linking photos that a route declares (the defaults when it declares none).

    Parameters
    ----------
    route : Route
        The route whose params may set ``max_pair_deg``, ``min_overlap`` and the rest.

    Returns
    -------
    MatchRule
        The rule the evaluator links photos by.
    """
    d = MatchRule()
    return MatchRule(float(route.params.get("max_pair_deg") or d.max_pair_deg),
                     float(route.params.get("min_overlap") or d.min_overlap),
                     int(route.params.get("min_neighbours") or d.min_neighbours),
                     link_test=str(route.params.get("link_test") or d.link_test))


def shot_graph(route: Route, samples: SurfaceSamples, pairs) -> dict:
    """Which photos SfM should match (reconstructability.py), measured on these samples.

    Parameters
    ----------
    route : Route
        The route judged.
    samples : SurfaceSamples
        The evaluator's samples of the target surface.
    pairs : tuple of (m,) int arrays
        Photo index, sample index and a third array for every visible (photo, sample) pair.

    Returns
    -------
    dict
        The link graph's summary (components, weak photos) with the rule it used.
    """
    import scipy.sparse as sp

    cam, pt, _ = pairs
    n = len(photo_poses(route)[0])
    vis = sp.csr_matrix((np.ones(len(cam)), (cam, pt)), shape=(n, len(samples)))
    rule = match_rule(route)
    summary = graph_summary(shot_links(vis, photo_poses(route)[0], samples.points, rule, normals=samples.normals), rule)
    summary.update({"max_pair_deg": rule.max_pair_deg, "min_overlap": rule.min_overlap,
                    "min_neighbours": rule.min_neighbours, "link_test": rule.link_test})
    return summary


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


def _metrics(ev: Evaluation, scene, limits: ViewLimits) -> dict:
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
