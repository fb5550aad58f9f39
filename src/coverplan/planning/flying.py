"""The flight: lattice, Dijkstra, tour, legs and the battery split."""

from __future__ import annotations

from concurrent.futures import Executor
from dataclasses import dataclass

import numpy as np

from coverplan.errors import PlanningError
from coverplan.flight.battery import (
    MissionItems,
    Stops,
    split_flights,
    waypoint_times,
)
from coverplan.flight.pathing import (
    FlightGraph,
    build_flight_graph,
    closure_hops,
    leg,
    shortcut,
    shot_distances,
)
from coverplan.flight.route import polyline_length
from coverplan.flight.tour import lane_costs, plan_tour, reaim_costs, typical_step
from coverplan.planning.gaps import ClosedGaps
from coverplan.planning.problem import Problem
from coverplan.planning.setup import Setup, plan_lattice_spacing
from coverplan.progress import Progress
from coverplan.shots.candidates import (
    Candidates,
)
from coverplan.shots.lane_selection import ring_pairs


@dataclass(frozen=True)
class Flight:
    """The tour flown: waypoints per battery flight, the shots they photograph from, and what
    stays uncovered (shots no safe path reaches dropped).

    Parameters
    ----------
    flights : list
        Waypoints and shot flags of each battery flight.
    shots : Candidates
        The poses photographed from.
    chosen : (k,) int
        The chosen candidates the flight reaches.
    check : object
        The fine check of the shots flown.
    uncovered : list
        What stays uncovered, with the reason.
    lattice_spacing_m : float
        The flight graph's lattice spacing.
    single_flight_s : float
        The tour's time as one flight.
    single_flight_path_m : float
        The tour's length as one flight.
    reversal_m : float
        The tour's cost of a reversal, in metres of path.
    reaim_m : float
        The tour's cost of a step that turns the camera.
    """

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
    the Dijkstra searches.

    Parameters
    ----------
    scene : Scene
        The scene flown.
    problem : Problem
        The candidates and the lattice started for them.
    gaps : ClosedGaps
        The shots to fly to.
    setup : Setup
        The resolved settings.
    progress : Progress
        Reports the searches.
    pool : Executor, optional
        Runs the Dijkstra searches beside this thread.

    Returns
    -------
    Flight
        The tour, its legs and flights.
    """
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
        h = plan_lattice_spacing(scene, shots.positions, setup)
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
            reaim = reaim + lane_costs(ring_pairs(problem.lanes, new[new < len(problem.lanes)]), new,
                                       settings.lane_steps * step)
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
