"""plan(): scene + camera + detail + security distance -> one safe flight covering the target.

Stages (DESIGN.md's pipeline): surface samples -> reachability -> candidate viewpoints ->
visibility matrix -> view selection -> flight graph -> tour -> legs -> Route.
"""

from __future__ import annotations

import os
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace

import numpy as np

from .camera import Camera, check_positive
from .candidates import along_normals, facade_rings, from_probes, keep_safe, standoff, under_overhangs
from .errors import ParameterError, PlanningError
from .drones import security_shortfall
from .margin import NO_MARGIN, margin_for, tightened
from .flights import Stops, flight_table, split_flights, transit_headings, waypoint_times
from .flighttime import FlightModel
from .pathing import (build_flight_graph, build_lattice, closure_hops, lattice_box, lattice_spacing, leg,
                      shortcut, shot_distances)
from .progress import Progress
from .reconstructability import (SHARP_INCIDENCE_DEG, MatchRule, add_sharp_views, best_incidence, candidate_links,
                                 connect_shots, extend_links, incidence_deg, sharp_view_matrix, shot_links)
from .reachability import ViewLimits, reachability, scene_limits
from .route import Route, polyline_length
from .redundancy import CheckViews, SharpViews, drop_redundant
from .relink import relink_on_check
from .repair import MAX_ROUNDS, TARGET_PCT, CoverProblem, GapCloser, check_samples, planner_check_spacing
from .selection import select_views
from .surface import default_spacing, sample_surface
from .tour import solve_tour
from .visibility import pair_stats, view_rays

MAX_LATTICE_NODES = 150_000


def safety_margin(security: float) -> float:
    """Extra clearance the planner keeps beyond the security distance."""
    return max(0.05, 0.02 * security)


def check_settings(camera: Camera, gsd, security, min_views, min_triangulation_deg,
                   max_incidence_deg, min_altitude) -> tuple[float, float, float]:
    """Validate the plan settings; returns (gsd, security, d_opt)."""
    gsd = check_positive("gsd", gsd)
    security = check_positive("security distance", security)
    if int(min_views) != min_views or min_views < 1:
        raise ParameterError(f"min views must be a whole number >= 1, got {min_views!r}")
    if not 0 <= float(min_triangulation_deg) < 90:
        raise ParameterError(f"min triangulation angle must be in [0, 90) degrees, got {min_triangulation_deg!r}")
    if not 0 < float(max_incidence_deg) < 90:
        raise ParameterError(f"max incidence must be in (0, 90) degrees, got {max_incidence_deg!r}")
    if min_altitude is not None and not np.isfinite(min_altitude):
        raise ParameterError(f"min altitude must be a finite number, got {min_altitude!r}")
    d_opt = camera.optimal_distance(gsd)
    need = security + safety_margin(security)
    if d_opt <= need * 1.05:
        finest = need * 1.05 * camera.pixel_pitch_mm / camera.focal_length_mm
        raise PlanningError(
            f"GSD {gsd:g} m/px needs shots within {d_opt:.2f} m of the surface, but the security "
            f"distance is {security:g} m; the finest GSD possible with this camera and security "
            f"distance is about {finest:.4g} m/px")
    return gsd, security, d_opt


# Bytes per item, measured on the 3.2-million-triangle benchmark mesh and sample scenes
# (peak resident memory over the counts), rounded up.
BYTES_PER_TRIANGLE = 1400
BYTES_PER_SAMPLE = 3000
BYTES_PER_VIEW_PAIR = 160
BYTES_PER_CANDIDATE = 400


def physical_memory() -> float:
    """Bytes of RAM on this machine (sysconf), or 8 GB where it cannot be read."""
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 8e9


def memory_estimate(scene, camera: Camera, spacing: float, distance: float) -> dict:
    """Rough peak memory of a plan, from triangles, samples and expected visibility pairs."""
    triangles = sum(len(p.mesh.faces) for p in scene.parts)
    area = sum(p.mesh.area for p in scene.targets)
    samples = area / spacing ** 2
    width, height = camera.footprint(distance)
    candidates = 12.0 * area / max(width * height, spacing ** 2) + 500.0
    per_view = min(samples, width * height / spacing ** 2)
    pairs = candidates * per_view * 0.6
    total = (triangles * BYTES_PER_TRIANGLE + samples * BYTES_PER_SAMPLE + pairs * BYTES_PER_VIEW_PAIR
             + candidates * BYTES_PER_CANDIDATE + 3e8)
    return {"bytes": total, "triangles": triangles, "samples": samples, "candidates": candidates, "pairs": pairs}


def check_size(scene, camera: Camera, spacing: float, distance: float, max_memory: float | None) -> dict:
    """Refuse, before any heavy work, a plan that would not fit in memory."""
    limit = 0.8 * physical_memory() if max_memory is None else float(max_memory)
    est = memory_estimate(scene, camera, spacing, distance)
    if est["bytes"] > limit:
        raise PlanningError(
            f"this plan needs about {est['bytes'] / 1e9:.1f} GB ({est['triangles']:,} triangles, "
            f"~{est['samples']:,.0f} surface samples at {spacing:.3g} m, ~{est['pairs']:,.0f} view pairs) but "
            f"the limit is {limit / 1e9:.1f} GB; use a coarser --spacing or GSD, or raise --max-memory-gb")
    return est


def default_start(scene, limits: ViewLimits, margin: float) -> np.ndarray:
    """A point just outside the shot region, north-west of the target, at the minimum altitude."""
    lo, hi = scene.bounds("target")
    clearance = scene.clearance_model(limits.security)
    centre = (lo + hi) / 2.0
    for extra in np.arange(1.0, 20.0, 1.0) * max(limits.d_opt, 1.0):
        angles = np.radians(np.arange(135.0, 135.0 + 360.0, 15.0))
        r = np.linalg.norm(hi[:2] - lo[:2]) / 2.0 + extra
        xy = np.column_stack([centre[0] + r * np.cos(angles), centre[1] + r * np.sin(angles)])
        pts = np.column_stack([xy, limits.floor_at(xy)])
        ok = clearance.points_clear(pts, limits.security + margin)
        if ok.any():
            return pts[np.argmax(ok)]
    raise PlanningError("found no safe start point near the target; give one with --start X Y Z")


MAX_START_DISTANCE_M = 5_000.0  # farther than any battery flies: a coordinate mix-up


def check_start(scene, start, limits: ViewLimits, notes: list) -> np.ndarray:
    start = np.asarray(start, dtype=float).reshape(3)
    if not np.isfinite(start).all():
        raise ParameterError(f"start point must be three finite numbers, got {start.tolist()}")
    lo, hi = scene.bounds("target")
    away = float(np.linalg.norm(np.maximum(np.maximum(lo - start, start - hi), 0.0)))
    if away > MAX_START_DISTANCE_M:
        centre = scene.to_source((lo + hi) / 2.0)
        raise ParameterError(
            f"start point is {away / 1000:,.0f} km from the target; give it in the same coordinates as the input "
            f"models (the target's centre is at {', '.join(f'{v:.1f}' for v in centre)})")
    floor = float(limits.floor_at(start[None, :2])[0])
    if start[2] < floor:
        notes.append(f"start raised from z={start[2]:.2f} to the minimum altitude z={floor:.2f}"
                     + (" above the terrain" if limits.terrain is not None else ""))
        start = start.copy()
        start[2] = floor
    inside = scene.rays.inside(start[None])[0]
    if inside >= 0:
        raise PlanningError(f"start point {start.round(2).tolist()} is inside {scene.describe(int(inside))}")
    clearance = scene.clearance_model(limits.security)
    d, which = clearance.point_distance(start[None])
    if d[0] < limits.security:
        raise PlanningError(f"start point {start.round(2).tolist()} is {d[0]:.2f} m from "
                            f"{scene.describe(int(which[0]))}, closer than the security distance "
                            f"{limits.security:g} m")
    return start


RULES = ("sfm", "thesis")


def plan(scene, camera: Camera, *, gsd: float, security: float, start=None, min_views: int | None = None,
         min_triangulation_deg: float = 5.0, rule: str = "sfm", match: MatchRule | None = None, max_incidence_deg: float = 70.0,
         min_altitude: float | None = None, spacing: float | None = None,
         gimbal_pitch_range_deg=None, cost_weight: float = 1.0, drone=None,
         flight_model: FlightModel | None = None, max_flight_min: float | None = None,
         lattice_spacing_m: float | None = None, lp_time_limit: float = 20.0,
         max_memory: float | None = None, surface_classes=None, pose_margin: str = "field",
         progress: Progress | None = None) -> Route:
    """Plan one flight from ``start`` over shots covering the target and back.

    ``rule`` "sfm" (default) plans for a reconstruction (reconstructability.py): ``min_views``
    3, a pair per sample that both triangulates and matches, and shots linked into one
    matchable set; "thesis" is the thesis's rule (``min_views`` 2, any pair wide enough).
    ``start`` is in the scene's local frame (``scene.to_local`` moves a point of the input
    models there); a start more than 5 km from the target is refused as a coordinate mix-up.
    ``drone`` (drones.DroneProfile) gives the gimbal range, the flight-time model and the
    flight length; ``max_flight_min`` splits the tour into flights of at most that many minutes
    by the model, each from the start back to it (flights.py).
    ``pose_margin`` "field" (default) judges frames and pair angles with the drone's own pose
    error (margin.py: the profile's, or a GNSS drone's without ``drone``); "none" as given.
    Raises ParameterError / PlanningError (with a one-line message) on impossible settings;
    surface no safe position can image is planned around and listed in ``route.uncovered``.
    """
    t0 = time.perf_counter()
    progress = progress or Progress()
    if rule not in RULES:
        raise ParameterError(f"rule must be one of {', '.join(RULES)}, got {rule!r}")
    if min_views is None:
        min_views = 3 if rule == "sfm" else 2
    match = (match or MatchRule()) if rule == "sfm" else None
    max_pair = match.max_pair_deg if match else None
    if match and not float(min_triangulation_deg) < match.max_pair_deg:
        raise ParameterError(f"min triangulation angle {min_triangulation_deg:g} deg must be below the widest "
                             f"matchable pair {match.max_pair_deg:g} deg")
    gsd, security, d_opt = check_settings(camera, gsd, security, min_views, min_triangulation_deg,
                                          max_incidence_deg, min_altitude)
    min_views = int(min_views)
    min_alt = security if min_altitude is None else float(min_altitude)
    lo_p, hi_p = _gimbal_range(gimbal_pitch_range_deg, drone)
    model = flight_model or (drone.flight_model() if drone is not None else FlightModel())
    if max_flight_min is None and drone is not None:
        max_flight_min = drone.usable_flight_min
    if max_flight_min is not None:
        max_flight_min = check_positive("max flight minutes", max_flight_min)
    limits = scene_limits(scene, security=security, d_opt=d_opt, max_incidence_deg=max_incidence_deg,
                          min_altitude=min_alt, pitch_range_deg=(lo_p, hi_p), vfov_deg=camera.vfov_deg)
    margin = safety_margin(security)
    # The rules judged with the drone's pose error: a narrower frame, narrower pair angles.
    asked_camera, asked_tri, asked_match = camera, float(min_triangulation_deg), match
    pose = margin_for(pose_margin, drone, standoff(camera, limits, margin))
    if pose != NO_MARGIN:
        camera = pose.camera(camera)
        match, min_triangulation_deg = tightened(match, min_triangulation_deg, pose)
        max_pair = match.max_pair_deg if match else None
        if match and not min_triangulation_deg < match.max_pair_deg:
            raise ParameterError(f"with the pose margin the narrowest triangulating pair ({min_triangulation_deg:.1f} "
                                 f"deg) is not below the widest matchable one ({match.max_pair_deg:.1f} deg); "
                                 "widen --max-pair-deg or use --margin none")
        limits = replace(limits, vfov_deg=camera.vfov_deg)
    notes: list[str] = []
    spacing = default_spacing(scene, d_opt) if spacing is None else check_positive("spacing", spacing)
    distance = standoff(camera, limits, margin)
    check_size(scene, camera, spacing, distance, max_memory)
    start = default_start(scene, limits, margin) if start is None else check_start(scene, start, limits, notes)

    # The check samples depend on the target alone: drawn on another core meanwhile (Embree
    # and HiGHS release the GIL), they are ready when the repair needs them.
    background = ThreadPoolExecutor(max_workers=1)
    fine_job = background.submit(check_samples, scene, planner_check_spacing(scene, spacing), surface_classes)
    with progress.stage("surface samples"):
        samples = sample_surface(scene, spacing)
        if surface_classes:
            samples = samples.of_classes(surface_classes)
            if len(samples) == 0:
                raise PlanningError(f"the target has no {' or '.join(surface_classes)} surface")
    with progress.stage("reachability"):
        reach = reachability(scene, samples, limits)
    with progress.stage("candidate viewpoints"):
        cands = facade_rings(scene, camera, limits, distance, spacing).concat(
            along_normals(samples, limits, camera, distance)).concat(
            under_overhangs(samples, limits, camera, margin))
        cands = keep_safe(scene, cands, limits, margin)

    problem = CoverProblem(scene, camera, limits, samples, cands)
    with progress.stage("visibility matrix", total=len(cands), unit="cam") as update:
        problem.pairs = problem.pairs_between(cands, samples, progress=update)
        # Samples the structured candidates leave short get candidates from their own probes
        # (judged without the margin: they serve samples only grazing views reach).
        needy = _short_samples(problem.pairs, cands.positions, samples, min_views, min_triangulation_deg,
                               max_pair) & reach.reachable
        problem.add_candidates(keep_safe(scene, from_probes(scene, samples, np.flatnonzero(needy), limits),
                                         limits, margin))
    vis, rays = problem.matrices()
    reach = reach.with_witnesses(np.bincount(problem.pairs[1], minlength=len(samples)) > 0)
    # The candidates' link graph depends on vis alone: built on the other core while HiGHS
    # (which releases the GIL) solves the selection's LP, it is ready when linking starts.
    links_job = background.submit(candidate_links, vis, problem.cands.positions, samples.points,
                                  match) if match is not None else None
    # So is the flight graph's lattice when its spacing cannot depend on which shots are chosen
    # (build_flight_graph checks that the shots ask for this very lattice, or builds another).
    h = _lattice_spacing(scene, problem.cands.positions, d_opt, security, lattice_spacing_m)
    lattice_job = None
    if h == _lattice_spacing(scene, np.zeros((0, 3)), d_opt, security, lattice_spacing_m):
        lattice_job = background.submit(build_lattice, scene, limits, lattice_box(scene, limits, np.zeros((0, 3)), h),
                                         start, margin=margin, spacing=h)
    background.shutdown(wait=False)

    with progress.stage("view selection", unit="shot") as update:
        selection = select_views(vis, rays, min_views, min_triangulation_deg, lp_time_limit=lp_time_limit,
                                 progress=update, max_pair_deg=max_pair)
    covering = len(selection.chosen)
    lp_bound = selection.lp_bound
    if match is not None and match.sharp_views and len(selection.chosen):
        with progress.stage("sharp views for SfM"):
            cam, pt, _ = problem.pairs
            inc = incidence_deg(cam, pt, problem.cands.positions, samples.points, samples.normals)
            selection.chosen = add_sharp_views(cam, pt, inc, len(problem.cands), samples.area, selection.chosen,
                                               views=match.sharp_views)
    sharpening = len(selection.chosen) - covering
    if match is not None and len(selection.chosen):
        with progress.stage("linking shots for SfM"):
            selection.chosen = connect_shots(vis, problem.cands.positions, samples.points, selection.chosen, match,
                                             links=links_job.result())
    chosen = selection.chosen
    if len(chosen) == 0:
        raise PlanningError("no safe viewpoint can image any part of the target: "
                            + (reach.reason[0] if len(reach.reason) and reach.reason[0] else
                               "check the security distance and GSD"))
    with progress.stage("fine check and repair"):
        closer = GapCloser(problem, min_views, min_triangulation_deg, max_pair, distance, margin,
                           fine_job.result())
        check = closer.check(chosen)
        history = [check.coverage_pct]
        while check.coverage_pct < TARGET_PCT and len(history) <= MAX_ROUNDS and closer.extend(check):
            vis, rays = problem.matrices()
            before = len(chosen)
            chosen = select_views(vis, rays, min_views, min_triangulation_deg, lp_time_limit=0,
                                  max_pair_deg=max_pair, preset=chosen).chosen
            if match is not None:
                # Links are judged on the planner's own samples: the check samples crowd a few
                # strips that hundreds of candidates see, which makes the pair products explode.
                coarse = len(samples)
                chosen = _link_new_shots(vis[:, :coarse], problem.cands.positions, samples.points, chosen,
                                         before, match, 0.5 * d_opt, known=links_job.result())
            check = closer.check(chosen)
            history.append(check.coverage_pct)
        fine_sharp = 0
        if match is not None and match.sharp_views:
            before = len(chosen)
            chosen = closer.sharpen(chosen, match.sharp_views)
            if len(chosen) > before:  # sharpen leaves the problem as it was: vis still holds
                chosen = _link_new_shots(vis[:, :len(samples)], problem.cands.positions, samples.points, chosen,
                                         before, match, 0.5 * d_opt, known=links_job.result())
                fine_sharp = len(chosen) - before
                check = closer.check(chosen)
        complete = len(chosen)
        if match is not None:
            chosen = _drop_redundant(problem, closer, chosen, check.covered, len(samples), vis, match)
            check = closer.kept(check, chosen)
        dropped = complete - len(chosen)
        check_links = 0
        if match is not None:
            kept = len(chosen)
            chosen = relink_on_check(problem, closer, chosen, match, vis[:, :len(samples)])
            check_links = len(chosen) - kept
            if check_links:
                check = closer.check(chosen)
    cands = problem.cands
    shots = cands.subset(chosen)
    with progress.stage("lattice and Dijkstra"):
        specials = np.vstack([start, shots.positions])
        h = _lattice_spacing(scene, shots.positions, d_opt, security, lattice_spacing_m)
        lattice = lattice_job.result() if lattice_job is not None else None
        fg = build_flight_graph(scene, limits, specials, margin=margin, spacing=h, cost_weight=cost_weight,
                                lattice=lattice)
        limit = 4.0 * max(d_opt, 3 * h) * (1.0 + 2.0 * cost_weight)
        closure, pred, direct = shot_distances(fg, len(specials), limit)
    flyable = np.isfinite(closure[0])
    if not flyable[1:].any():
        raise PlanningError("no safe path from the start point to any shot; move the start point")
    if not flyable.all():
        # Shots the start cannot reach (a pocket no safe path enters): drop them, and say what
        # their samples lose.
        notes.append(f"{int((~flyable[1:]).sum())} shots have no safe path from the start and were dropped")
        chosen = chosen[flyable[1:]]
        check = closer.check(chosen)
        shots = cands.subset(chosen)
        specials = np.vstack([start, shots.positions])
        fg = build_flight_graph(scene, limits, specials, margin=margin, spacing=h, cost_weight=cost_weight,
                                lattice=lattice)
        closure, pred, direct = shot_distances(fg, len(specials), limit)
    check = closer.edge_of_hidden(check, chosen)
    uncovered = closer.uncovered(check, lost_path=not flyable.all())
    with progress.stage("tour"):
        order = solve_tour(closure)
    stops = Stops(np.concatenate([[0.0], shots.heading_deg]), np.concatenate([[0.0], shots.pitch_deg]),
                  float(start[2] - limits.ground_at(start[None, :2])[0]))
    with progress.stage("legs"):
        flights = [_fly(fg, order, pred, direct, scene, limits, margin)]
    single_s = waypoint_times(model, flights[0], stops)["total_s"]
    single_path = polyline_length([p for p, _ in flights[0]])
    if max_flight_min is not None and single_s > 60.0 * max_flight_min:
        with progress.stage("battery flights"):
            flights = split_flights(fg, order, closure, lambda o: _fly(fg, o, pred, direct, scene, limits, margin),
                                    model, stops, 60.0 * max_flight_min, scene.clearance_model(limits.security),
                                    limits.security + margin, floor=limits.segments_above_floor)
    route = _route(flights, shots, asked_camera, scene, limits, gsd, security, min_views,
                   asked_tri, max_incidence_deg, min_alt, spacing, uncovered)
    route.params["pose_margin"] = dict(pose.to_dict(), kind=pose_margin)
    if drone is not None:
        route.params["drone"] = drone.name
    shortfall = security_shortfall(security, drone)
    if shortfall:
        notes.append(f"WARNING {shortfall}: a position error that large can bring the drone closer than the "
                     "security distance")
    if max_flight_min is not None:
        route.params["max_flight_min"] = max_flight_min
    if surface_classes:
        route.params["surface_classes"] = list(surface_classes)
    route.params["rule"] = rule
    if asked_match is not None:
        route.params.update({"max_pair_deg": asked_match.max_pair_deg, "min_overlap": asked_match.min_overlap,
                             "min_neighbours": asked_match.min_neighbours, "sharp_views": asked_match.sharp_views})
    _final_check(route, scene, limits)

    fine = check.samples
    route.metrics = {
        "shots": int(route.shot.sum()),
        "selected_views": int(len(chosen)),
        "sharp_view_shots": int(sharpening + fine_sharp),
        "linking_shots": int(max(len(selection.chosen) - covering - sharpening, 0) + check_links),
        "repair_shots": int(max(complete - len(selection.chosen) - fine_sharp, 0)),
        "redundant_shots_dropped": int(dropped),
        "check_link_shots": int(check_links),  # of the linking shots: those the check samples' links asked
        "repair_rounds": len(history) - 1,
        "check_coverage_history_pct": history,
        "path_length_m": route.path_length,
        "planned_coverage_pct": check.coverage_pct,
        "check_spacing_m": fine.spacing,
        "reachable_area_m2": float(fine.area[check.reachable].sum()),
        "surface_area_m2": fine.total_area,
        "planning_time_s": time.perf_counter() - t0,
        "stage_seconds": dict(progress.timings),
        "candidates": int(len(cands)),
        "samples": int(len(samples)),
        "standoff_m": distance,
        "d_opt_m": d_opt,
        "lattice_spacing_m": h,
        "orbit_length_m": _orbit_length(scene, distance),
        "flight_model": model.to_dict(),
        "flights": flight_table(route, model, max_flight_min),
        "single_flight_path_m": single_path,
        "single_flight_min": single_s / 60.0,
    }
    if lp_bound is not None:
        route.metrics["lp_lower_bound_shots"] = lp_bound
    route.extra = {"notes": notes + list(scene.notes), "target_outline": _outline(scene)}
    return route


def _lattice_spacing(scene, shots: np.ndarray, d_opt: float, security: float, given: float | None) -> float:
    """The flight graph's lattice spacing: ``given``, or one that keeps the lattice over the
    target and its shots within MAX_LATTICE_NODES."""
    region = np.ptp(np.vstack([scene.bounds("target"), shots]), axis=0) + 2 * (d_opt + security)
    return given or lattice_spacing(d_opt, security, float(np.prod(region)), MAX_LATTICE_NODES)


def _link_new_shots(vis, positions, points, chosen, before: int, match: MatchRule, radius: float,
                    known=None) -> np.ndarray:
    """connect_shots after a repair round, over the chosen shots and the candidates within
    ``radius`` of the new ones (linking over every candidate again costs seconds). ``known``:
    the links among the first candidates (``candidate_links``), which are not worked out again."""
    from scipy.spatial import cKDTree

    if len(chosen) == before:
        return chosen
    near = np.isfinite(cKDTree(positions[chosen[before:]]).query(positions, distance_upper_bound=radius)[0])
    pool = np.union1d(chosen, np.flatnonzero(near))
    links = None
    if known is not None:
        old = pool[pool < known.shape[0]]  # pool is sorted: these come first
        links = extend_links(vis[pool], positions[pool], points, match, known[old][:, old])
    linked = connect_shots(vis[pool], positions[pool], points, np.searchsorted(pool, chosen), match, links=links)
    return pool[linked]


def _drop_redundant(problem: CoverProblem, closer: GapCloser, chosen: np.ndarray, covered: np.ndarray,
                    coarse: int, vis, match: MatchRule) -> np.ndarray:
    """``drop_redundant`` keeping the fine check's coverage, the links between the shots and the
    sharp views: on the planner's samples as the sharp-view stage asked them, on the check
    samples a view as square as 35 deg or as the plan's best (between the planner's samples
    1-2 m apart the gabled house's roof lost its square views)."""
    n_cands = len(problem.cands)
    who, at = closer.firm_views()
    mine = np.isin(who, chosen)
    who, at = who[mine], at[mine]
    positions, fine = problem.cands.positions, closer.fine
    views = CheckViews(who, at, view_rays(who, at, positions, fine.points), covered,
                       closer.min_views, closer.min_tri, closer.max_pair)
    sharp = []
    if match.sharp_views:
        cam, pt, _ = problem.pairs
        own = pt < coarse
        inc = incidence_deg(cam[own], pt[own], positions, problem.samples.points, problem.samples.normals)
        sharp.append(SharpViews(sharp_view_matrix(cam[own], pt[own], inc, n_cands, coarse), match.sharp_views))
        inc = incidence_deg(who, at, positions, fine.points, fine.normals)
        best = np.maximum(best_incidence(at, inc, len(fine)), SHARP_INCIDENCE_DEG)
        sharp.append(SharpViews(sharp_view_matrix(who, at, inc, n_cands, len(fine), targets=best), match.sharp_views))
    links = shot_links(vis[chosen][:, :coarse], positions[chosen], problem.samples.points[:coarse], match)
    return drop_redundant(chosen, views, sharp, links, match.min_neighbours)


def _short_samples(pairs, positions, samples, min_views, min_tri, max_pair=None) -> np.ndarray:
    cam, pt, _ = pairs
    views = np.bincount(pt, minlength=len(samples))
    rays = view_rays(cam, pt, positions, samples.points)
    widest, paired = pair_stats(pt, rays, len(samples), min_tri, max_pair)
    short = (views < min_views + 1) | (widest < min_tri * 2)
    return short | ~paired if max_pair is not None else short


def _fly(fg, order, pred, direct, scene, limits, margin) -> list[tuple[np.ndarray, int]]:
    """Waypoints along the tour: (position, special index or -1 for transit points)."""
    clearance = scene.clearance_model(limits.security)
    radius = limits.security + margin
    stops = list(order) + [0]
    out: list[tuple[np.ndarray, int]] = [(fg.points[fg.special(0)], 0)]
    for u, v in zip(stops[:-1], stops[1:]):
        hops = closure_hops(pred, u, v)
        nodes = [fg.special(hops[0])]
        for x, y in zip(hops[:-1], hops[1:]):
            nodes.extend(leg(fg, fg.special(x), fg.special(y), direct[x, y])[1:])
        pts = fg.points[np.array(nodes)]
        keep = shortcut(pts, clearance, radius, floor=limits.segments_above_floor)
        for k in keep[1:-1]:
            out.append((pts[k], -1))
        out.append((pts[-1], v))
    return out


def _route(flights, shots, camera, scene, limits, gsd, security, min_views,
           min_tri, max_inc, min_alt, spacing, uncovered) -> Route:
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
    params = {"gsd_m": gsd, "security_m": security, "min_views": min_views,
              "min_triangulation_deg": min_tri, "max_incidence_deg": max_inc,
              "min_altitude_m": min_alt, "ground_z_m": scene.ground_z,
              "gimbal_pitch_range_deg": list(limits.pitch_range_deg), "sample_spacing_m": spacing}
    ground = None
    if scene.terrain is not None:
        ground = scene.terrain.height(pos[:, :2])
        params["terrain"] = scene.terrain.source
    return Route(pos, is_shot, heading, pitch, legs, camera, params, frame=scene.frame, uncovered=uncovered,
                 flight=flight, ground_z=ground)


def _gimbal_range(given, drone) -> tuple[float, float]:
    """The gimbal pitch range to plan with: the one given, else the drone's, else -90..30."""
    rng = given if given is not None else (drone.gimbal_pitch_deg if drone is not None else (-90.0, 30.0))
    lo, hi = (float(v) for v in rng)
    if not -90.0 <= lo <= hi <= 90.0:
        raise ParameterError(f"gimbal pitch range must lie in [-90, 90] with min <= max, got {tuple(rng)}")
    if given is not None and drone is not None:
        d_lo, d_hi = drone.gimbal_pitch_deg
        if lo < d_lo or hi > d_hi:
            raise ParameterError(f"gimbal pitch range {lo:g}..{hi:g} deg is beyond the {drone.label}'s "
                                 f"{d_lo:g}..{d_hi:g} deg")
    return lo, hi


def _final_check(route: Route, scene, limits: ViewLimits) -> None:
    """Never hand out an unsafe route: every segment and waypoint checked once more."""
    clearance = scene.clearance_model(limits.security)
    p = route.positions
    ok = clearance.segments_clear(p[:-1], p[1:], limits.security) if len(p) > 1 else np.array([True])
    low = ~limits.above_floor(p)
    if len(p) > 1:
        low[1:] |= ~limits.segments_above_floor(p[:-1], p[1:])
    if not ok.all() or low.any():
        raise RuntimeError(f"internal error: planned route breaks the security distance on "
                           f"{int((~ok).sum())} segments / altitude at {int(low.sum())} waypoints or segments")


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
