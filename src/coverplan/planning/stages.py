"""The stages of :func:`coverplan.plan`, each taking the results of the ones before it.

setup -> problem (samples, reachability, candidates, visibility) -> selection (covering,
sharp views, links) -> closing the gaps (fine check, repair, redundancy, relinking) ->
flight (lattice, Dijkstra, tour, legs, battery split) -> route.
"""

from __future__ import annotations

from concurrent.futures import Executor, Future
from dataclasses import dataclass, replace

import numpy as np
import shapely
from scipy.spatial import cKDTree

from coverplan.equipment.camera import Camera
from coverplan.equipment.drones import TYPICAL_GNSS, DroneProfile, security_shortfall
from coverplan.equipment.flighttime import FlightModel
from coverplan.equipment.margin import NO_MARGIN, PoseMargin, margin_for, tightened
from coverplan.errors import ParameterError, PlanningError
from coverplan.flight.battery import (
    MissionItems,
    Stops,
    flight_table,
    split_flights,
    transit_headings,
    waypoint_times,
)
from coverplan.flight.lanes import route_step_shape
from coverplan.flight.passing import camera_timing, fly_through
from coverplan.flight.pathing import (
    FlightGraph,
    build_flight_graph,
    build_lattice,
    closure_hops,
    lattice_box,
    lattice_spacing,
    leg,
    polyline_checks,
    shortcut,
    shot_distances,
)
from coverplan.flight.route import Route, polyline_length
from coverplan.flight.start import check_start, default_start
from coverplan.flight.tour import lane_costs, plan_tour, reaim_costs, typical_step
from coverplan.flight.turning import add_turn_points
from coverplan.planning.settings import (
    PlanSettings,
    check_size,
    gimbal_range,
    optimal_distance,
    safety_margin,
)
from coverplan.progress import Progress
from coverplan.shots.bracing import brace_links
from coverplan.shots.candidates import (
    Candidates,
    along_normals,
    edge_views,
    facade_rings,
    from_probes,
    keep_safe,
    required_edge_views,
    standoff,
    under_overhangs,
)
from coverplan.shots.reachability import (
    Reachability,
    ViewLimits,
    reachability,
    scene_limits,
)
from coverplan.shots.reconstructability import (
    SHARP_INCIDENCE_DEG,
    MatchRule,
    add_sharp_views,
    add_wanted_views,
    best_incidence,
    candidate_links,
    connect_shots,
    extend_links,
    incidence_deg,
    sharp_view_matrix,
    shot_links,
)
from coverplan.shots.lane_selection import select_lanes
from coverplan.shots.lanes import NEAR_LANE_SHARE, Lanes, facade_lanes, roof_lanes, safe_lanes
from coverplan.shots.framing import (
    CLOSE_SHARE,
    frame_fill,
    framed_view_matrix,
    short_of_framing,
    view_fill,
)
from coverplan.shots.redundancy import TRIM_SPARE_VIEWS, CheckViews, SharpViews, drop_redundant
from coverplan.shots.relink import check_views, relink_on_check
from coverplan.shots.repair import (
    MAX_ROUNDS,
    TARGET_PCT,
    CoverProblem,
    GapCloser,
    check_samples,
    planner_check_spacing,
)
from coverplan.shots.selection import select_views
from coverplan.shots.surface import SurfaceSamples, default_spacing, sample_surface
from coverplan.shots.visibility import has_pair_between, imaging_pairs, view_rays

MAX_LATTICE_NODES = 150_000


@dataclass(frozen=True)
class Setup:
    """The settings resolved against the scene, camera and drone: what every stage works with.

    ``camera``, ``match`` and ``min_triangulation_deg`` are the ones the rules are judged with
    (narrowed by the pose margin); ``asked`` keeps the settings as given for the route.
    """

    asked: PlanSettings
    asked_camera: Camera
    camera: Camera
    limits: ViewLimits
    pose: PoseMargin
    match: MatchRule | None
    min_triangulation_deg: float
    d_opt: float
    extra_clearance: float  # beyond the security distance (safety_margin)
    spacing: float
    standoff: float
    start: np.ndarray  # (3,)
    flight_model: FlightModel
    max_flight_min: float | None
    drone: DroneProfile | None
    notes: tuple

    @property
    def max_pair_deg(self) -> float | None:
        return self.match.max_pair_deg if self.match else None


def resolve(scene, camera: Camera, settings: PlanSettings, drone: DroneProfile | None = None,
            flight_model: FlightModel | None = None, start=None) -> Setup:
    """Check the settings against the camera and scene; the pose margin, limits and start point."""
    d_opt = optimal_distance(camera, settings)
    pitch_range = gimbal_range(settings.gimbal_pitch_range_deg, drone)
    model = flight_model or (drone.flight_model() if drone is not None else FlightModel())
    max_flight_min = settings.max_flight_min
    if max_flight_min is None and drone is not None:
        max_flight_min = drone.usable_flight_min
    limits = scene_limits(scene, security=settings.security, d_opt=d_opt, max_incidence_deg=settings.max_incidence_deg,
                          min_altitude=settings.floor, pitch_range_deg=pitch_range, vfov_deg=camera.vfov_deg,
                          max_altitude=settings.max_altitude, zones=settings.zones.grown(zone_margin(settings, drone)))
    extra = safety_margin(settings.security)
    # The rules judged with the drone's pose error: a narrower frame, narrower pair angles.
    asked_camera, match, min_tri = camera, settings.match, float(settings.min_triangulation_deg)
    pose = margin_for(settings.pose_margin, drone, standoff(camera, limits, extra))
    if pose != NO_MARGIN:
        camera = pose.camera(camera)
        match, min_tri = tightened(match, min_tri, pose)
        if match and not min_tri < match.max_pair_deg:
            raise ParameterError(f"with the pose margin the narrowest triangulating pair ({min_tri:.1f} "
                                 f"deg) is not below the widest matchable one ({match.max_pair_deg:.1f} deg); "
                                 "widen --max-pair-deg or use --margin none")
        limits = replace(limits, vfov_deg=camera.vfov_deg)
    spacing = default_spacing(scene, d_opt) if settings.spacing is None else settings.spacing
    distance = standoff(camera, limits, extra)
    check_size(scene, camera, spacing, distance, settings.max_memory)
    check_zones(scene, limits)
    notes = []
    if start is None:
        start = default_start(scene, limits, extra)
    else:
        start, notes = check_start(scene, start, limits)
    return Setup(settings, asked_camera, camera, limits, pose, match, min_tri, d_opt, extra, spacing, distance,
                 start, model, max_flight_min, drone, tuple(notes))


@dataclass(frozen=True)
class Problem:
    """Samples, where they can be seen from, the candidates and which candidate sees which sample.

    The futures are work started on the other core for later stages: the check samples, the
    candidates' link graph and the flight graph's lattice (None when it depends on the shots).
    """

    samples: SurfaceSamples
    reach: Reachability
    cover: CoverProblem
    vis: object  # (candidates, samples) sparse visibility
    rays: np.ndarray
    fine_job: Future
    links_job: Future | None
    lattice_job: Future | None
    fixed: np.ndarray  # (k,) candidate indices of photos already taken (settings.existing)
    required: np.ndarray  # (k,) candidate indices every plan takes: the edge views (settings.edge_views)
    fill: np.ndarray  # (candidates, N_BINS) frame_fill of the candidates (framing.py); no columns without framed views
    lanes: Lanes  # the lane photos: the first len(lanes) candidates (settings.selection "lanes")

    def lane_of(self, n: int) -> np.ndarray:
        """(n,) int: the lane of each of the first ``n`` candidates, -1 for those not in a lane."""
        out = np.full(n, -1, dtype=np.int64)
        out[:len(self.lanes)] = self.lanes.lane
        return out

    @property
    def kept(self) -> np.ndarray:
        """(k,) candidate indices every plan keeps: the photos already taken and the required ones."""
        return np.union1d(self.fixed, self.required)


def build_problem(scene, setup: Setup, progress: Progress, pool: Executor) -> Problem:
    """Surface samples, reachability, candidate viewpoints and the visibility matrix."""
    settings, limits, camera = setup.asked, setup.limits, setup.camera
    classes = settings.surface_classes
    # The check samples depend on the target alone: drawn on another core meanwhile (Embree
    # and HiGHS release the GIL), they are ready when the repair needs them.
    fine_job = pool.submit(check_samples, scene, planner_check_spacing(scene, setup.spacing), classes)
    with progress.stage("surface samples"):
        samples = sample_surface(scene, setup.spacing)
        if classes:
            samples = samples.of_classes(classes)
            if len(samples) == 0:
                raise PlanningError(f"the target has no {' or '.join(classes)} surface")
    with progress.stage("reachability"):
        reach = reachability(scene, samples, limits)
    lanes = Lanes.empty()
    if settings.selection == "lanes":
        with progress.stage("lanes"):
            near = max(NEAR_LANE_SHARE * setup.standoff, 1.2 * (limits.security + setup.extra_clearance))
            lanes = Lanes.empty()
            for distance in (setup.standoff, near):  # near: courtyards and recesses the standoff does not fit
                lanes = lanes.concat(facade_lanes(scene, camera, limits, distance, settings.forward_overlap,
                                                  settings.side_overlap))
            lanes = lanes.concat(roof_lanes(scene, samples, camera, limits, setup.standoff, settings.forward_overlap,
                                            settings.side_overlap))
            lanes = safe_lanes(scene, lanes, limits, setup.extra_clearance)
    with progress.stage("candidate viewpoints"):
        cands = facade_rings(scene, camera, limits, setup.standoff, setup.spacing,
                             view_tilts=settings.view_tilts).concat(
            along_normals(samples, limits, camera, setup.standoff,
                          n_tilts=4 if settings.view_tilts == "varied" else 0))
        if settings.edge_views:
            cands = cands.concat(edge_views(samples, limits, camera, setup.standoff))
        cands = keep_safe(scene, cands.concat(under_overhangs(samples, limits, camera, setup.extra_clearance)),
                          limits, setup.extra_clearance)
        cands = lanes.cands.concat(cands)  # lane photos first: Problem.lane_of

    cover = CoverProblem(scene, camera, limits, samples, cands)
    with progress.stage("visibility matrix", total=len(cands), unit="cam") as update:
        cover.pairs = cover.pairs_between(cands, samples, progress=update)
        # Samples the structured candidates leave short get candidates from their own probes
        # (judged without the margin: they serve samples only grazing views reach).
        needy = _short_samples(cover.pairs, cands.positions, samples, settings.min_views, setup.min_triangulation_deg,
                               setup.max_pair_deg) & reach.reachable
        cover.add_candidates(keep_safe(scene, from_probes(scene, samples, np.flatnonzero(needy), limits),
                                       limits, setup.extra_clearance))
    framing = setup.match is not None and setup.match.framed_views > 0
    fill = np.zeros((len(cover.cands), 0), dtype=np.float32)  # frame_fill's, when framed views are asked
    if framing:
        with progress.stage("framing"):
            fill = _fill_of(scene, cover.cands, setup)
            # Faces that no candidate at the standoff frames well (towers, chimneys, spires) get
            # candidates closer in along their normals.
            cam, pt, _ = cover.pairs
            inc = incidence_deg(cam, pt, cover.cands.positions, samples.points, samples.normals)
            short = short_of_framing(cam, pt, view_fill(fill, cam, pt, samples.normals), inc, len(samples),
                                     setup.match.framed_views) & reach.reachable
            if short.any():
                near = max(setup.standoff * CLOSE_SHARE, (limits.security + setup.extra_clearance) * 1.05)
                close = keep_safe(scene, along_normals(samples.subset(short), limits, camera, near), limits,
                                  setup.extra_clearance)
                cover.add_candidates(close)
                fill = np.vstack([fill, _fill_of(scene, close, setup)])
    fixed = np.zeros(0, dtype=np.int64)
    if settings.existing is not None:  # taken, not flown: no safety or gimbal test
        with progress.stage("photos already taken"):
            base = len(cover.cands)
            existing = settings.existing.candidates()
            cover.add_candidates(existing)
            fill = np.vstack([fill, _fill_of(scene, existing, setup) if framing else
                              np.zeros((len(existing), 0), dtype=np.float32)])
            fixed = np.arange(base, len(cover.cands))
    vis, rays = cover.matrices()
    reach = reach.with_witnesses(np.bincount(cover.pairs[1], minlength=len(samples)) > 0)
    # The candidates' link graph depends on vis alone: built on the other core while HiGHS
    # (which releases the GIL) solves the selection's LP, it is ready when linking starts.
    links_job = pool.submit(candidate_links, vis, cover.cands.positions, samples.points,
                            setup.match, normals=samples.normals) if setup.match is not None else None
    # So is the flight graph's lattice when its spacing cannot depend on which shots are chosen
    # (build_flight_graph checks that the shots ask for this very lattice, or builds another).
    h = _lattice_spacing(scene, cover.cands.positions, setup)
    lattice_job = None
    if h == _lattice_spacing(scene, np.zeros((0, 3)), setup):
        lattice_job = pool.submit(build_lattice, scene, limits, lattice_box(scene, limits, np.zeros((0, 3)), h),
                                  setup.start, margin=setup.extra_clearance, spacing=h)
    required = required_edge_views(cover.cands, camera, setup.standoff, vis.getnnz(axis=1),
                                   taken=cover.cands.subset(fixed)) \
        if settings.edge_views and settings.selection == "shots" else np.zeros(0, dtype=np.int64)
    return Problem(samples, reach, cover, vis, rays, fine_job, links_job, lattice_job, fixed, required, fill, lanes)


@dataclass(frozen=True)
class Selection:
    """The shots chosen on the planner's samples and how many each step added."""

    chosen: np.ndarray  # (k,) int candidate indices
    covering: int
    sharpening: int
    framing: int
    lp_bound: float | None
    lp_stopped: bool  # the LP reached its time limit (selection.Selection.lp_stopped)
    lane_rows: np.ndarray  # (k,) int candidate indices of the lane photos chosen (settings.selection "lanes")

    def keep(self, problem: Problem) -> np.ndarray:
        """(k,) candidate indices no later stage drops: the problem's kept ones and the lanes."""
        return np.union1d(problem.kept, self.lane_rows)


def select_shots(problem: Problem, setup: Setup, progress: Progress) -> Selection:
    """View selection (covering LP), then sharp views and links for SfM."""
    settings, match = setup.asked, setup.match
    cam, pt, _ = problem.cover.pairs
    samples, cands = problem.samples, problem.cover.cands
    inc = None  # the views' incidences, for the sharp and framed views
    if match is not None and (match.sharp_views or match.framed_views):
        inc = incidence_deg(cam, pt, cands.positions, samples.points, samples.normals)
    # Lean selection (``lean``): the cover is chosen with a sharp view for every sample in view,
    # not patched with them after.
    wanted = sharp_view_matrix(cam, pt, inc, len(cands), len(samples)) \
        if lean(match) and match.sharp_views else None
    lane_rows = np.zeros(0, dtype=np.int64)
    if len(problem.lanes):
        with progress.stage("lane selection"):
            lane_rows = select_lanes(problem.vis, problem.lane_of(len(cands)), samples.area, settings.min_views)
    preset = np.union1d(problem.kept, lane_rows)
    with progress.stage("view selection", unit="shot") as update:
        selection = select_views(problem.vis, problem.rays, settings.min_views, setup.min_triangulation_deg,
                                 lp_time_limit=settings.lp_time_limit, progress=update, max_pair_deg=setup.max_pair_deg,
                                 preset=preset if len(preset) else None, wanted=wanted)
    chosen = selection.chosen
    covering = len(chosen)
    if match is not None and match.sharp_views and len(chosen):
        with progress.stage("sharp views for SfM"):
            chosen = add_sharp_views(cam, pt, inc, len(cands), samples.area, chosen, views=match.sharp_views)
    sharpening = len(chosen) - covering
    if match is not None and match.framed_views and len(chosen):
        with progress.stage("framed views for SfM"):
            framed = framed_view_matrix(cam, pt, view_fill(problem.fill, cam, pt, samples.normals), inc, len(cands),
                                        len(samples))
            chosen = add_wanted_views(framed, samples.area, chosen, views=match.framed_views)
    framing = len(chosen) - covering - sharpening
    if match is not None and len(chosen):
        with progress.stage("linking shots for SfM"):
            chosen = connect_shots(problem.vis, cands.positions, samples.points, chosen, match,
                                   links=problem.links_job.result())
    if len(chosen) == 0:
        reason = problem.reach.reason
        raise PlanningError("no safe viewpoint can image any part of the target: "
                            + (reason[0] if len(reason) and reason[0] else "check the security distance and GSD"))
    return Selection(chosen, covering, sharpening, framing, selection.lp_bound, selection.lp_stopped, lane_rows)


@dataclass(frozen=True)
class ClosedGaps:
    """The shots after the fine check: repaired, sharpened, thinned and relinked.

    ``cover`` is the problem grown by the repair's candidates and the check samples.
    """

    cover: CoverProblem
    chosen: np.ndarray  # (k,) int candidate indices into cover.cands
    check: object  # repair.Check of ``chosen``
    closer: GapCloser
    history: list
    fine_sharp: int
    complete: int
    dropped: int
    check_links: int
    trimmed: int  # shots the final trim dropped (``_trim``)


def close_gaps(problem: Problem, selection: Selection, setup: Setup, progress: Progress) -> ClosedGaps:
    """Judge the shots on the check samples; add shots where they fall short, drop the
    redundant ones, link what the check's samples ask."""
    settings, match, d_opt = setup.asked, setup.match, setup.d_opt
    samples, coarse = problem.samples, len(problem.samples)
    cover = replace(problem.cover)  # the repair grows its own copy of the problem
    chosen, vis = selection.chosen, problem.vis
    known = problem.links_job.result() if problem.links_job is not None else None
    with progress.stage("fine check and repair"):
        passing = settings.pass_rules.max_photo_offset_m if settings.fly == "through" else 0.0
        closer = GapCloser(cover, settings.min_views, setup.min_triangulation_deg, setup.max_pair_deg, setup.standoff,
                           setup.extra_clearance, problem.fine_job.result(), sight_m=passing)
        check = closer.check(chosen)
        history = [check.coverage_pct]
        while check.coverage_pct < TARGET_PCT and len(history) <= MAX_ROUNDS and closer.extend(check):
            vis, rays = cover.matrices()
            before = len(chosen)
            chosen = select_views(vis, rays, settings.min_views, setup.min_triangulation_deg, lp_time_limit=0,
                                  max_pair_deg=setup.max_pair_deg, preset=chosen).chosen
            if match is not None:
                # Links are judged on the planner's own samples: the check samples crowd a few
                # strips that hundreds of candidates see, which makes the pair products explode.
                chosen = _link_new_shots(vis[:, :coarse], cover.cands.positions, samples, chosen,
                                         before, match, 0.5 * d_opt, known=known)
            check = closer.check(chosen)
            history.append(check.coverage_pct)
        fine_sharp = 0
        if match is not None and match.sharp_views:
            before = len(chosen)
            chosen = closer.sharpen(chosen, match.sharp_views)
            if len(chosen) > before:  # sharpen leaves the problem as it was: vis still holds
                chosen = _link_new_shots(vis[:, :coarse], cover.cands.positions, samples, chosen,
                                         before, match, 0.5 * d_opt, known=known)
                fine_sharp = len(chosen) - before
                check = closer.check(chosen)
        complete = len(chosen)
        if match is not None:
            fill = problem.fill
            if match.framed_views:  # the repair's candidates too
                added = cover.cands.subset(np.arange(len(fill), len(cover.cands)))
                fill = np.vstack([fill, _fill_of(cover.scene, added, setup)])
            chosen = _drop_redundant(cover, closer, chosen, check.covered, coarse, vis, match, fill,
                                     keep=selection.keep(problem))
            check = closer.kept(check, chosen)
        dropped = complete - len(chosen)
        check_links = 0
        if match is not None:
            kept = len(chosen)
            chosen = relink_on_check(cover, closer, chosen, match, vis[:, :coarse])
            if match.braced:
                chosen = brace_links(cover, closer, chosen, match, vis[:, :coarse])
            check_links = len(chosen) - kept
            if check_links:
                check = closer.check(chosen)
        trimmed = 0
        if lean(match) and len(chosen) > 2:
            before = len(chosen)
            chosen = _trim(cover, closer, chosen, check, coarse, vis, match, fill, selection.keep(problem))
            trimmed = before - len(chosen)
            if trimmed:
                check = closer.kept(check, chosen)
    return ClosedGaps(cover, chosen, check, closer, history, fine_sharp, complete, dropped, check_links, trimmed)


@dataclass(frozen=True)
class Flight:
    """The tour flown: waypoints per battery flight, the shots they photograph from, and what
    stays uncovered (shots no safe path reaches dropped)."""

    flights: list  # per battery flight: [(position (3,), special index or -1), ...]
    shots: Candidates
    chosen: np.ndarray
    check: object
    uncovered: list
    lattice_spacing_m: float
    single_flight_s: float
    single_flight_path_m: float
    reversal_m: float  # the tour's cost of a reversal
    reaim_m: float  # and of a step that turns the camera


def fly(scene, problem: Problem, gaps: ClosedGaps, setup: Setup, progress: Progress,
        pool: Executor | None = None) -> Flight:
    """Flight graph (lattice + Dijkstra), tour, legs and the battery split; ``pool`` shares
    the Dijkstra searches."""
    limits, settings, extra = setup.limits, setup.asked, setup.extra_clearance
    closer, chosen, check = gaps.closer, gaps.chosen, gaps.check
    cands = gaps.cover.cands
    taken = np.isin(chosen, problem.fixed)
    new, taken = chosen[~taken], chosen[taken]
    if not len(new):
        raise PlanningError(f"the {len(taken)} existing photos already give every view the rules ask; "
                            "there is nothing to fly")
    shots = cands.subset(new)
    with progress.stage("lattice and Dijkstra"):
        specials = np.vstack([setup.start, shots.positions])
        h = _lattice_spacing(scene, shots.positions, setup)
        lattice = problem.lattice_job.result() if problem.lattice_job is not None else None
        fg = build_flight_graph(scene, limits, specials, margin=extra, spacing=h, cost_weight=settings.cost_weight,
                                lattice=lattice)
        limit = 4.0 * max(setup.d_opt, 3 * h) * (1.0 + 2.0 * settings.cost_weight)
        closure, pred, direct = shot_distances(fg, len(specials), limit, pool)
    flyable = np.isfinite(closure[0])
    if not flyable[1:].any():
        raise PlanningError("no safe path from the start point to any shot; move the start point")
    if not flyable.all():
        # Shots the start cannot reach (a pocket no safe path enters): drop them, and say what
        # their samples lose.
        new = new[flyable[1:]]
        chosen = np.concatenate([taken, new])
        check = closer.check(chosen)
        shots = cands.subset(new)
        specials = np.vstack([setup.start, shots.positions])
        fg = build_flight_graph(scene, limits, specials, margin=extra, spacing=h, cost_weight=settings.cost_weight,
                                lattice=lattice)
        closure, pred, direct = shot_distances(fg, len(specials), limit, pool)
    check = closer.edge_of_hidden(check, chosen)
    uncovered = closer.uncovered(check, lost_path=not flyable.all())
    with progress.stage("tour"):
        step = typical_step(closure)
        reversal_m, reaim_m = settings.reversal_steps * step, settings.reaim_steps * step
        heading, pitch = np.concatenate([[0.0], shots.heading_deg]), np.concatenate([[0.0], shots.pitch_deg])
        reaim = reaim_costs(heading, pitch, reaim_m)
        if len(problem.lanes):
            reaim = reaim + lane_costs(problem.lane_of(len(cands)), new, settings.lane_steps * step)
        order = plan_tour(closure, specials, reversal_m, reaim)
    stops = Stops(heading, pitch,
                  float(setup.start[2] - limits.ground_at(setup.start[None, :2])[0]))

    def fly_order(o):
        return _legs(fg, o, pred, direct, scene, limits, extra)

    with progress.stage("legs"):
        flights = [fly_order(order)]
    single_s = waypoint_times(setup.flight_model, flights[0], stops)["total_s"]
    single_path = polyline_length([p for p, _ in flights[0]])
    max_s = np.inf if setup.max_flight_min is None else 60.0 * setup.max_flight_min
    items = None if settings.max_mission_items is None else \
        MissionItems(settings.max_mission_items, through=settings.fly == "through")
    if single_s > max_s or (items is not None and items.bound(flights[0], stops) > items.limit):
        with progress.stage("battery flights"):
            def tour(nodes):
                return plan_tour(closure[np.ix_(nodes, nodes)], specials[nodes], reversal_m, reaim[np.ix_(nodes, nodes)])

            flights = split_flights(fg, order, tour, fly_order, setup.flight_model, stops, max_s,
                                    scene.clearance_model(limits.security), limits.security + extra,
                                    floor=limits.segments_allowed, items=items)
    return Flight(flights, shots, chosen, check, uncovered, h, single_s, single_path, reversal_m, reaim_m)


def make_route(scene, setup: Setup, problem: Problem, selection: Selection, gaps: ClosedGaps, flight: Flight,
               stage_seconds: dict, planning_time_s: float) -> Route:
    """The Route: waypoints, the settings as asked, notes and the plan's metrics; checked once
    more for safety before it is handed out."""
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
                       "braced_links": match.braced, "link_test": match.link_test})
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
        "edge_view_shots": int(len(np.intersect1d(chosen, problem.required))),
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


def _lattice_spacing(scene, shots: np.ndarray, setup: Setup) -> float:
    """The flight graph's lattice spacing: the one asked, or one that keeps the lattice over the
    target and its shots within MAX_LATTICE_NODES."""
    security = setup.asked.security
    region = np.ptp(np.vstack([scene.bounds("target"), shots]), axis=0) + 2 * (setup.d_opt + security)
    return setup.asked.lattice_spacing_m or lattice_spacing(setup.d_opt, security, float(np.prod(region)),
                                                            MAX_LATTICE_NODES)


def _link_new_shots(vis, positions, samples, chosen, before: int, match: MatchRule, radius: float,
                    known=None) -> np.ndarray:
    """connect_shots after a repair round, over the chosen shots and the candidates within
    ``radius`` of the new ones (linking over every candidate again costs seconds). ``known``:
    the links among the first candidates (``candidate_links``), which are not worked out again."""
    if len(chosen) == before:
        return chosen
    near = np.isfinite(cKDTree(positions[chosen[before:]]).query(positions, distance_upper_bound=radius)[0])
    pool = np.union1d(chosen, np.flatnonzero(near))
    links = None
    if known is not None:
        old = pool[pool < known.shape[0]]  # pool is sorted: these come first
        links = extend_links(vis[pool], positions[pool], samples.points, match, known[old][:, old],
                             normals=samples.normals)
    linked = connect_shots(vis[pool], positions[pool], samples.points, np.searchsorted(pool, chosen), match,
                           links=links, normals=samples.normals)
    return pool[linked]


def _drop_redundant(cover: CoverProblem, closer: GapCloser, chosen: np.ndarray, covered: np.ndarray,
                    coarse: int, vis, match: MatchRule, fill: np.ndarray, keep=None, links=None,
                    braced: bool = False, spare_views: int = 0) -> np.ndarray:
    """``drop_redundant`` keeping the fine check's coverage, the links between the shots, the
    sharp views (on the planner's samples as the sharp-view stage asked them, on the check
    samples a view as square as 35 deg or as the plan's best, docs/reconstruction.md) and the
    framed views on the planner's samples. ``fill``: ``frame_fill`` of every candidate."""
    n_cands = len(cover.cands)
    who, at = closer.firm_views()
    mine = np.isin(who, chosen)
    who, at = who[mine], at[mine]
    positions, fine = cover.cands.positions, closer.fine
    views = CheckViews(who, at, view_rays(who, at, positions, fine.points), covered,
                       closer.min_views, closer.min_triangulation_deg, closer.max_pair_deg)
    sharp = []
    if match.sharp_views:
        cam, pt, _ = cover.pairs
        own = pt < coarse
        inc = incidence_deg(cam[own], pt[own], positions, cover.samples.points, cover.samples.normals)
        sharp.append(SharpViews(sharp_view_matrix(cam[own], pt[own], inc, n_cands, coarse), match.sharp_views))
        inc = incidence_deg(who, at, positions, fine.points, fine.normals)
        best = np.maximum(best_incidence(at, inc, len(fine)), SHARP_INCIDENCE_DEG)
        sharp.append(SharpViews(sharp_view_matrix(who, at, inc, n_cands, len(fine), targets=best), match.sharp_views))
    if match.framed_views:
        cam, pt, _ = cover.pairs
        own = pt < coarse
        cam, pt = cam[own], pt[own]
        normals = cover.samples.normals
        inc = incidence_deg(cam, pt, positions, cover.samples.points, normals)
        sharp.append(SharpViews(framed_view_matrix(cam, pt, view_fill(fill, cam, pt, normals), inc, n_cands, coarse),
                                match.framed_views))
    if links is None:
        links = shot_links(vis[chosen][:, :coarse], positions[chosen], cover.samples.points[:coarse], match,
                           normals=cover.samples.normals[:coarse])
    return drop_redundant(chosen, views, sharp, links, match.min_neighbours, keep=keep, braced=braced,
                          spare_views=spare_views)


def lean(match: MatchRule | None) -> bool:
    """Whether the plan is chosen lean: the cover with its sharp views, pieces joined through
    the chains already added (``connect_shots``), and a final trim (``_trim``). Only under the
    "samples" link test: under "centroid" the same rules met with fewer photos split the gabled
    house's model in two field draws of three (its links across corners are not COLMAP's), so
    those plans keep the slack the classic selection leaves (docs/reconstruction.md)."""
    return match is not None and match.lean


def _trim(cover: CoverProblem, closer: GapCloser, chosen: np.ndarray, check, coarse: int, vis, match: MatchRule,
          fill: np.ndarray, keep) -> np.ndarray:
    """The finished shots less those the rest make redundant, judged as ``_drop_redundant``
    judges them but on the links of the check samples (as the relink and the bracing judge
    them), with no new cut photo when the links are braced, and with one view to spare on
    every check sample a dropped shot covered: the plan keeps a view more than its rule asks
    wherever it had one, the margin the field runs need (docs/reconstruction.md)."""
    fine = closer.fine
    links = candidate_links(check_views(closer, chosen, len(cover.cands)), cover.cands.positions[chosen],
                            fine.points, match, normals=fine.normals).toarray() > 0
    np.fill_diagonal(links, False)
    return _drop_redundant(cover, closer, chosen, check.covered, coarse, vis, match, fill, keep=keep,
                           links=links, braced=match.braced, spare_views=TRIM_SPARE_VIEWS)


def _fill_of(scene, cands: Candidates, setup: Setup) -> np.ndarray:
    """``frame_fill`` of candidates, framed by the camera asked for (not the one narrowed by the
    pose margin: exposure and features come from the whole frame)."""
    return frame_fill(scene, cands.positions, cands.heading_deg, cands.pitch_deg, setup.asked_camera)


def _short_samples(pairs, positions, samples, min_views, min_triangulation_deg, max_pair_deg=None) -> np.ndarray:
    cam, pt, _ = pairs
    views = np.bincount(pt, minlength=len(samples))
    rays = view_rays(cam, pt, positions, samples.points)
    short = (views < min_views + 1) | ~has_pair_between(pt, rays, len(samples), min_triangulation_deg * 2, None)
    if max_pair_deg is None:
        return short
    return short | ~has_pair_between(pt, rays, len(samples), min_triangulation_deg, max_pair_deg)


def _legs(fg: FlightGraph, order, pred, direct, scene, limits, margin) -> list[tuple[np.ndarray, int]]:
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
        keep = shortcut(pts, clearance, radius, floor=limits.segments_allowed)
        for k in keep[1:-1]:
            out.append((pts[k], -1))
        out.append((pts[-1], v))
    return out


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


def zone_margin(settings: PlanSettings, drone: DroneProfile | None) -> float:
    """The margin the flight keeps from the zones, m: the one asked, else the drone's
    horizontal position accuracy (a GNSS drone's without a profile)."""
    if settings.zone_margin is not None:
        return float(settings.zone_margin)
    return float((drone.position if drone is not None else TYPICAL_GNSS).horizontal_m)


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


def check_zones(scene, limits: ViewLimits) -> None:
    """Refuse zones that leave no airspace to photograph the target from."""
    if not limits.zones:
        return
    for zone in limits.zones.keep_in:
        if zone.polygon.is_empty or zone.floor >= zone.ceiling:
            raise ParameterError(f"{zone.label} is narrower than twice the zone margin (--zone-margin): "
                                 "no room to fly inside it")
    pts = np.vstack([p.mesh.vertices for p in scene.targets])
    reach = limits.d_opt
    outline = shapely.MultiPoint(pts[:, :2]).convex_hull.buffer(reach)
    low = float(limits.floor_at(pts[:, :2]).min())
    high = float(pts[:, 2].max() + reach)
    closed = limits.zones.closing_off(outline, low, high)
    if closed and closed[0].startswith("keep-out"):
        raise ParameterError(f"{' and '.join(closed)} cover{'s' if len(closed) == 1 else ''} the whole target and "
                             f"the airspace within d_opt {reach:.1f} m of it: nothing could be photographed")
    if closed:
        raise ParameterError(f"{' and '.join(closed)} do{'es' if len(closed) == 1 else ''} not reach within d_opt "
                             f"{reach:.1f} m of the target: nothing could be photographed from inside it")


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
