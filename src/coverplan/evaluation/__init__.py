"""The measuring instrument: does this route cover this building, safely?

Everything here is recomputed from the route file and the scene (its own surface samples,
ray casts and FCL distance queries); nothing is read from the planner's bookkeeping.
"""

from __future__ import annotations

import numpy as np

from coverplan.errors import ParameterError
from coverplan.evaluation.metrics import route_metrics
from coverplan.evaluation.photos import photo_poses, shot_graph
from coverplan.evaluation.result import Evaluation
from coverplan.flight.route import Route
from coverplan.shots.limits import ViewLimits, scene_limits
from coverplan.shots.reachability import reachability
from coverplan.shots.surface import SurfaceSamples, check_spacing, sample_surface
from coverplan.shots.visibility import imaging_pairs, pair_stats, view_rays
from coverplan.world.zones import Zones

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
    # Reach is judged with the margin the planner kept from the zones; breaches (route_metrics) exactly.
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
    ev.metrics = route_metrics(ev, scene, limits)
    ev.metrics["rule"] = rule
    ev.metrics["shot_graph"] = shot_graph(route, samples, pairs)
    return ev
