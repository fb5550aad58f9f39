"""The Route handed out: waypoints, the settings as asked, notes and metrics, checked once more."""

from __future__ import annotations

import numpy as np

from coverplan.equipment.drones import security_shortfall
from coverplan.equipment.margin import NO_MARGIN
from coverplan.flight.battery import (
    flight_table,
    transit_headings,
)
from coverplan.flight.lanes import route_step_shape
from coverplan.flight.passing import camera_timing, fly_through
from coverplan.flight.pathing import (
    polyline_checks,
)
from coverplan.flight.route import Route
from coverplan.flight.turning import add_turn_points
from coverplan.planning.flying import Flight
from coverplan.planning.gaps import ClosedGaps
from coverplan.planning.problem import Problem
from coverplan.planning.selecting import Selection, lean
from coverplan.planning.settings import (
    PlanSettings,
)
from coverplan.planning.setup import Setup, zone_margin
from coverplan.shots.candidates import (
    Candidates,
)
from coverplan.shots.limits import ViewLimits
from coverplan.shots.visibility import imaging_pairs


def make_route(scene, setup: Setup, problem: Problem, selection: Selection, gaps: ClosedGaps, flight: Flight,
               stage_seconds: dict, planning_time_s: float) -> Route:
    """The Route: waypoints, the settings as asked, notes and the plan's metrics; checked once
    more for safety before it is handed out.

    Parameters
    ----------
    scene : Scene
        The scene planned.
    setup : Setup
        The resolved settings.
    problem : Problem
        The samples and candidates.
    selection : Selection
        The shots chosen on the planner's samples.
    gaps : ClosedGaps
        The shots after the fine check.
    flight : Flight
        The tour and its battery flights.
    stage_seconds : dict
        Seconds per stage, recorded in the metrics.
    planning_time_s : float
        The plan's wall time.

    Returns
    -------
    Route
        The planned route.

    Raises
    ------
    RuntimeError
        When the assembled route comes closer than the security distance to the scene (a bug).
    """
    settings, limits = setup.asked, setup.limits
    route = _route(flight.flights, flight.shots, setup.asked_camera, scene, limits, settings, setup.spacing,
                   _witnessed(flight.uncovered, flight.shots, setup, scene))
    match = settings.match
    params = route.params
    if settings.zones:
        params["zone_margin_m"] = zone_margin(settings, setup.drone)
    params["pose_margin"] = dict(setup.pose.to_dict(), kind=settings.pose_margin)
    if setup.drone is not None:
        params["drone"] = setup.drone.name
    notes = list(setup.notes)
    lost = len(gaps.chosen) - len(flight.chosen)
    if lost:
        notes.append(f"{lost} shots have no safe path from the start and were dropped")
    shortfall = security_shortfall(settings.security, setup.drone)
    if shortfall:
        notes.append(f"WARNING {shortfall}: a position error that large can bring the drone closer than the "
                     "security distance")
    if settings.view_tilts != "varied":
        notes.append(f"WARNING view tilts {settings.view_tilts}: with fewer tilted views the links across corners "
                     "are weaker than the link test counts (a field simulate of the gabled house split in two); "
                     "run coverplan simulate --conditions field before flying it")
    if selection.lp_stopped:
        notes.append(f"WARNING view selection: the LP stopped at its time limit ({settings.lp_time_limit:g} s), so the "
                     "shots were chosen without it and can differ from run to run with the machine's speed; "
                     "give it more time (--lp-time-limit)")
    if lean(setup.match):
        notes.append("WARNING link test samples: a lean plan, flown under field conditions three times only on the gabled "
                     "house and the chapel; run coverplan simulate --conditions field before flying it")
    if setup.max_flight_min is not None:
        params["max_flight_min"] = setup.max_flight_min
    if settings.max_mission_items is not None:
        params["max_mission_items"] = settings.max_mission_items
    if settings.surface_classes:
        params["surface_classes"] = list(settings.surface_classes)
    params["rule"] = settings.rule
    params["reversal_steps"] = settings.reversal_steps
    params["reversal_m"] = round(flight.reversal_m, 3)
    params["reaim_steps"] = settings.reaim_steps
    params["selection"] = settings.selection
    if settings.selection == "lanes":
        params.update(forward_overlap=settings.forward_overlap, side_overlap=settings.side_overlap,
                      lane_steps=settings.lane_steps)
    params["reaim_m"] = round(flight.reaim_m, 3)
    if settings.view_tilts != "varied":
        params["view_tilts"] = settings.view_tilts
    params["edge_views"] = settings.edge_views
    if match is not None:
        params.update({"max_pair_deg": match.max_pair_deg, "min_overlap": match.min_overlap,
                       "min_neighbours": match.min_neighbours, "sharp_views": match.sharp_views,
                       "framed_views": match.framed_views,
                       "braced_links": match.braced, "min_cut": match.min_cut, "link_test": match.link_test})
    through = None
    if settings.fly == "through":
        route = add_turn_points(route, settings.pass_rules.turn_share)
    _final_check(route, scene, limits)
    if settings.fly == "through":
        through = fly_through(route, scene, limits, setup.flight_model,
                              **camera_timing(setup.asked_camera, setup.drone, setup.flight_model),
                              rules=settings.pass_rules)
        params["fly"] = "through"

    check, chosen = flight.check, flight.chosen
    fine = check.samples
    picked = len(selection.chosen)
    route.metrics = {
        "shots": int(route.shot.sum()),
        "selected_views": int(len(chosen)),
        "sharp_view_shots": int(selection.sharpening + gaps.fine_sharp),
        "framed_view_shots": int(selection.framing),
        "edge_view_shots": int(len(np.intersect1d(chosen, selection.required))),
        "lane_shots": int(np.count_nonzero(chosen < len(problem.lanes))),
        "lanes": int(len(np.unique(problem.lanes.lane[chosen[chosen < len(problem.lanes)]]))),
        "linking_shots": int(max(picked - selection.covering - selection.sharpening - selection.framing, 0)
                             + gaps.check_links),
        "repair_shots": int(max(gaps.complete - picked - gaps.fine_sharp, 0)),
        "redundant_shots_dropped": int(gaps.dropped),
        "check_link_shots": int(gaps.check_links),  # of the linking shots: those the check samples' links asked
        "trimmed_shots": int(gaps.trimmed),
        "repair_rounds": len(gaps.history) - 1,
        "check_coverage_history_pct": gaps.history,
        "path_length_m": route.path_length,
        "planned_coverage_pct": check.coverage_pct,
        "check_spacing_m": fine.spacing,
        "reachable_area_m2": float(fine.area[check.reachable].sum()),
        "surface_area_m2": fine.total_area,
        "planning_time_s": planning_time_s,
        "stage_seconds": dict(stage_seconds),
        "candidates": int(len(gaps.cover.cands)),
        "samples": int(len(problem.samples)),
        "standoff_m": setup.standoff,
        "d_opt_m": setup.d_opt,
        "lattice_spacing_m": flight.lattice_spacing_m,
        "orbit_length_m": _orbit_length(scene, setup.standoff),
        "flight_model": setup.flight_model.to_dict(),
        "flights": flight_table(route, setup.flight_model, setup.max_flight_min),
        "single_flight_path_m": flight.single_flight_path_m,
        "single_flight_min": flight.single_flight_s / 60.0,
    }
    route.metrics["smooth_steps_pct"], route.metrics["reversals_per_100"] = route_step_shape(route)
    if through is not None:
        route.metrics["fly_through"] = through
    if settings.existing is not None:
        ex = settings.existing
        params["existing_photos"] = {"count": len(ex), "source": ex.source,
                                     "positions": np.round(ex.positions, 4).tolist(),
                                     "heading_deg": np.round(ex.heading_deg, 4).tolist(),
                                     "pitch_deg": np.round(ex.pitch_deg, 4).tolist()}
        used = np.intersect1d(chosen, problem.fixed)
        route.metrics["existing"] = {"photos": len(settings.existing), "kept": int(len(used)),
                                     "coverage_pct": gaps.closer.check(used).coverage_pct,
                                     "new_shots": int(route.shot.sum())}
    if selection.lp_bound is not None:
        route.metrics["lp_lower_bound_shots"] = selection.lp_bound
    route.extra = {"notes": notes + list(scene.notes), "target_outline": _outline(scene)}
    return route


def _route(flights, shots, camera, scene, limits, settings: PlanSettings, spacing: float, uncovered) -> Route:
    waypoints = [w for flight in flights for w in flight]
    flight = np.concatenate([np.full(len(f), k) for k, f in enumerate(flights, start=1)])
    pos = np.array([p for p, _ in waypoints])
    special = np.array([s for _, s in waypoints])
    n = len(pos)
    is_shot = special > 0
    heading = np.zeros(n)
    pitch = np.zeros(n)
    shot_idx = special[is_shot] - 1
    heading[is_shot] = shots.heading_deg[shot_idx]
    pitch[is_shot] = shots.pitch_deg[shot_idx]
    heading = transit_headings(pos, is_shot, heading)
    legs = []
    for k in range(1, len(flights) + 1):  # initial / coverage / final within each flight
        rows = np.flatnonzero(flight == k)
        shot_rows = rows[is_shot[rows]]
        first, final = shot_rows[0], shot_rows[-1]
        legs += ["initial" if r < first else "final" if r > final else "coverage" for r in rows]
    params = {"gsd_m": settings.gsd, "security_m": settings.security, "min_views": settings.min_views,
              "min_triangulation_deg": float(settings.min_triangulation_deg),
              "max_incidence_deg": settings.max_incidence_deg, "min_altitude_m": settings.floor,
              "ground_z_m": scene.ground_z, "gimbal_pitch_range_deg": list(limits.pitch_range_deg),
              "sample_spacing_m": spacing, "max_altitude_m": settings.max_altitude}
    if settings.zones:
        params["zones"] = settings.zones.to_list()
    ground = None
    if scene.terrain is not None:
        ground = scene.terrain.height(pos[:, :2])
        params["terrain"] = scene.terrain.source
    if scene.source is not None:
        params["scene"] = scene.source
    return Route(pos, is_shot, heading, pitch, legs, camera, params, frame=scene.frame, uncovered=uncovered,
                 flight=flight, ground_z=ground)


def _final_check(route: Route, scene, limits: ViewLimits) -> None:
    """Never hand out an unsafe route: every segment and waypoint checked once more."""
    p = route.positions
    ok, inside = polyline_checks(p, scene.clearance_model(limits.security), limits)
    if len(p) < 2:
        inside = limits.allowed(p)
    if not ok.all() or not inside.all():
        raise RuntimeError(f"internal error: planned route breaks the security distance on "
                           f"{int((~ok).sum())} segments / altitude or zones on {int((~inside).sum())} segments")


def _witnessed(uncovered: list[dict], shots: Candidates, setup: Setup, scene) -> list[dict]:
    """The uncovered list with the samples the pose margin's narrower frame called unreachable
    but a shot images with the whole frame (as the evaluator judges it) marked reachable."""
    lost = [k for k, u in enumerate(uncovered) if not u["reachable"]]
    if not lost or len(shots) == 0 or setup.pose == NO_MARGIN:
        return uncovered
    points = np.array([uncovered[k]["position"] for k in lost])
    normals = np.array([uncovered[k]["normal"] for k in lost])
    _cam, pt, _ = imaging_pairs(shots.positions, shots.heading_deg, shots.pitch_deg, setup.asked_camera, points,
                                normals, scene.rays,
                                max_range=setup.limits.d_opt, max_incidence_deg=setup.limits.max_incidence_deg,
                                offset=scene.epsilon * 4)
    out = list(uncovered)
    for j in np.unique(pt):
        out[lost[j]] = dict(out[lost[j]], reachable=True,
                            reason="seen only near a frame's edge, within the drone's pose margin")
    return out


def _outline(scene) -> list:
    """The target's footprint (convex hull, local x y) at ground height, for maps."""
    from shapely.geometry import MultiPoint
    pts = np.vstack([p.mesh.vertices[:, :2] for p in scene.targets])
    hull = MultiPoint(pts).convex_hull
    coords = np.asarray(hull.exterior.coords) if hull.geom_type == "Polygon" else pts[:1]
    return [[round(float(x), 4), round(float(y), 4), float(scene.ground_z)] for x, y in coords]


def _orbit_length(scene, distance: float) -> float:
    """Length of one horizontal orbit at the standoff around the target's footprint."""
    from shapely.geometry import MultiPoint
    pts = np.vstack([p.mesh.vertices[:, :2] for p in scene.targets])
    return float(MultiPoint(pts).convex_hull.buffer(distance).exterior.length)
