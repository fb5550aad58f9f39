"""Battery-sized flights: the planned tour split into flights that each start and end at the
start point and fit one battery by the flight-time model.

Route first, cluster second (Prins 2004's split for vehicle routing): the single tour over all
shots, read in either direction, is cut into consecutive runs by a shortest-path search over
all cut positions, each run costing its take-off and landing, the legs from the start to its
first shot and back from its last, the legs between its shots and its photos; runs longer
than the limit are not allowed. The best split by total flight time wins; each flight's own
order is then improved as a tour from the start (tour.py) and kept if that is faster. All legs
are the safe legs the planner flies (Dijkstra over the lattice, shortcut where safe).

A flight can also be bounded in mission items (``MissionItems``): PX4 keeps at most 500 on a
flight controller, and a long flight flown through needs about two items a waypoint. The
split then cuts where a flight would outgrow the autopilot, not only the battery.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse.csgraph import dijkstra

from coverplan.equipment.flighttime import FlightModel, leg_seconds
from coverplan.errors import PlanningError
from coverplan.flight.pathing import shortcut
from coverplan.flight.route import polyline_length
from coverplan.flight.turning import camera_turns
from coverplan.geometry.orientation import heading_pitch

MAX_ATTEMPTS = 6
RUN_ITEMS = 4  # take-off, return, the first photo's gimbal command and its photo


def transit_headings(positions, is_shot, heading) -> np.ndarray:
    """Headings with transit points facing the way they fly (straight up or down: the last heading).

    Parameters
    ----------
    positions : (n, 3) float
        Waypoints.
    is_shot : (n,) bool
        Which take a photo.
    heading : (n,) float
        Degrees.

    Returns
    -------
    (n,) float
        Degrees.
    """
    pos = np.asarray(positions, dtype=float)
    out = np.array(heading, dtype=float)
    n = len(pos)
    last = 0.0
    for k in range(n):
        if is_shot[k]:
            last = out[k]
            continue
        step = pos[min(k + 1, n - 1)] - pos[k]
        if np.hypot(step[0], step[1]) > 1e-6:
            last = float(heading_pitch(np.array([step[0], step[1], 0.0]))[0])
        out[k] = last
    return out


@dataclass(frozen=True)
class MissionItems:
    """At most ``limit`` mission items per flight, counted as the QGroundControl plan and the
    WPL file write a flight (io/qgc.py): take-off and return, one waypoint command per waypoint
    after the start, turn points between photos included (flight/turning.py), a speed change
    before each when the route is flown ``through``, one photo command per photo and a gimbal
    command where the pitch changes (the first photo's always). Each term is counted where it
    may occur, so the count is an upper bound of what the writer writes.

    Parameters
    ----------
    limit : int
        Mission items allowed per flight.
    through : bool
        The route is flown through (a speed change before each waypoint).
    """

    limit: int
    through: bool = True

    @property
    def per_waypoint(self) -> int:
        """Items per waypoint: the waypoint command, and a speed change when flown through."""
        return 2 if self.through else 1

    def bound(self, waypoints, stops: Stops) -> int:
        """The most items one flight ([(position, special or -1), ...], a photo or more) can come to.

        Parameters
        ----------
        waypoints : list of ((3,) float, int)
            The flight's waypoints and special indices.
        stops : Stops
            The specials' orientations.

        Returns
        -------
        int
            Mission items.
        """
        special = np.array([s for _, s in waypoints])
        rows = np.flatnonzero(special > 0)
        shots = special[rows]
        return (RUN_ITEMS + self.per_waypoint * (len(special) - 1)
                + int(self.step_items(stops, shots[:-1], shots[1:], np.diff(rows) == 1).sum()))

    def step_items(self, stops: Stops, a, b, direct) -> np.ndarray:
        """Items a step from photo ``a`` to photo ``b`` (special indices) may add beyond its
        waypoints: ``b``'s photo command, two turn points where the legs join the photos
        directly and the camera turns (``add_turn_points``), a gimbal command where the pitch
        changes.

        Parameters
        ----------
        stops : Stops
            The specials' orientations.
        a, b : (k,) int
            Special indices.
        direct : (k,) bool
            Whether the leg joins the two photos directly.

        Returns
        -------
        (k,) int
            Mission items.
        """
        turning = np.asarray(direct, bool) & self.through & camera_turns(stops.heading[a], stops.pitch[a],
                                                                         stops.heading[b], stops.pitch[b])
        return 1 + 2 * self.per_waypoint * turning + (stops.pitch[b] != stops.pitch[a])


@dataclass
class Stops:
    """What the split needs to know of the specials (start 0, shots 1..n).

    Parameters
    ----------
    heading, pitch : (n + 1,) float
        Degrees per special.
    height_m : float
        The start's height above the ground.
    """

    heading: np.ndarray  # per special; start's entry unused
    pitch: np.ndarray
    height_m: float  # the start point above the ground (take-off and landing)


def waypoint_times(model: FlightModel, waypoints, stops: Stops) -> dict:
    """The model's time of one flight given as [(position, special or -1), ...].

    Parameters
    ----------
    model : FlightModel
        The time model.
    waypoints : list of ((3,) float, int)
        Position and special index (-1 for transit points).
    stops : Stops
        The specials' orientations.

    Returns
    -------
    dict
        ``FlightModel.flight_seconds``'s parts.
    """
    pos = np.array([p for p, _ in waypoints])
    special = np.array([s for _, s in waypoints])
    shot = special > 0
    heading = np.zeros(len(pos))
    pitch = np.zeros(len(pos))
    heading[shot] = stops.heading[special[shot]]
    pitch[shot] = stops.pitch[special[shot]]
    heading = transit_headings(pos, shot, heading)
    return model.flight_seconds(pos, shot, heading, pitch, stops.height_m)


def flight_table(route, model: FlightModel, limit_min: float | None = None) -> list[dict]:
    """Per flight of ``route``: minutes by ``model`` stopping at every waypoint where the path
    turns or a photo is taken (and their parts), shots, path length, and the share of the flight
    limit it uses.

    Parameters
    ----------
    route : Route
        The route.
    model : FlightModel
        The time model.
    limit_min : float, optional
        The flight limit, minutes.

    Returns
    -------
    list of dict
        One row per battery flight.
    """
    ground = route.takeoff_z
    corner = ~route.straight_points()  # no stop where the path runs straight on
    rows = []
    for k, idx in enumerate(route.flight_rows(), start=1):
        p = route.positions[idx]
        stop = idx[corner[idx]]
        parts = model.flight_seconds(route.positions[stop], route.shot[stop], route.heading_deg[stop],
                                     route.pitch_deg[stop], float(p[0, 2] - ground))
        minutes = parts["total_s"] / 60.0
        rows.append({"flight": k, "minutes": minutes, "shots": int(route.shot[idx].sum()),
                     "waypoints": int(len(idx)), "path_m": polyline_length(p),
                     "limit_share_pct": 100.0 * minutes / limit_min if limit_min else None,
                     **{k2: v for k2, v in parts.items() if k2 != "total_s"}})
    return rows


def _legs_of(waypoints) -> list[np.ndarray]:
    """Polylines between consecutive specials of a flown list."""
    legs, current = [], [waypoints[0][0]]
    for p, s in waypoints[1:]:
        current.append(p)
        if s >= 0:
            legs.append(np.array(current))
            current = [p]
    return legs


def _start_legs(fg, n_special: int, clearance, radius: float, floor=None) -> list[np.ndarray]:
    """The safe polyline from the start to every shot along one shortest-path tree."""
    source = fg.special(0)
    _dist, pred = dijkstra(fg.graph, directed=True, indices=source, return_predecessors=True)
    targets = fg.special(np.arange(1, n_special))
    hops = [targets]
    cur = targets.copy()
    while (cur != source).any():  # walk all paths back at once
        cur = np.where(cur == source, source, pred[cur])
        if (cur < 0).any():
            raise RuntimeError("a shot has no path from the start")
        hops.append(cur)
    hops = np.array(hops)  # (steps, shots), each column from its shot back to the source
    out = []
    for k in range(len(targets)):
        column = hops[:, k]
        nodes = column[: int(np.argmax(column == source)) + 1][::-1]
        pts = fg.points[nodes]
        out.append(pts[shortcut(pts, clearance, radius, floor=floor)])
    return out


def _best_split(sequence, start_s, between_s, photo_s, ground_s, limit_s, items=None):
    """Cut ``sequence`` (shot ids) into runs of at most ``limit_s`` minimising the total time.
    ``between_s[k]``: time from sequence[k] to sequence[k+1]. ``items``: None, or (items from
    the start to each special, items of each step, most items a run may have). Returns
    (total, cuts) or (inf, None)."""
    n = len(sequence)
    first = start_s[sequence]  # start -> shot, and back (legs are flown both ways)
    inner = np.concatenate([[0.0], np.cumsum(between_s)])  # inner[j] - inner[i]: legs i..j
    if items is not None:
        start_items, step_items, max_items = items
        reach = start_items[sequence]
        inner_items = np.concatenate([[0], np.cumsum(step_items)])
    best = np.full(n + 1, np.inf)
    best[0] = 0.0
    came = np.full(n + 1, -1)
    for i in range(n):
        if not np.isfinite(best[i]):
            continue
        j = np.arange(i, n)
        cost = ground_s + first[i] + (inner[j] - inner[i]) + first[j] + photo_s * (j - i + 1)
        fits = cost <= limit_s
        if items is not None:
            fits &= RUN_ITEMS + reach[i] + reach[j] + (inner_items[j] - inner_items[i]) <= max_items
        better = fits & (best[i] + cost < best[j + 1])
        best[j[better] + 1] = best[i] + cost[better]
        came[j[better] + 1] = i
    if not np.isfinite(best[n]):
        return np.inf, None
    cuts, j = [], n
    while j > 0:
        cuts.append((came[j], j))
        j = came[j]
    return best[n], cuts[::-1]


def split_flights(fg, order, tour, fly, model: FlightModel, stops: Stops, max_seconds: float,
                  clearance, radius: float, floor=None, items: MissionItems | None = None) -> list[list]:
    """Flights (each a flown waypoint list from the start back to it) covering every shot of
    the tour ``order`` once, each within ``max_seconds`` by ``model`` (``inf``: no time limit)
    and, given ``items``, within its mission items. ``tour(nodes)`` orders a flight's nodes
    (the start first) as the planner orders the whole tour; a flight keeps that order where it
    is quicker than the cut.

    Parameters
    ----------
    fg : FlightGraph
        The flight graph.
    order : (n + 1,) int
        Special indices of the whole tour, the start first.
    tour : callable
        Orders a flight's special indices.
    fly : callable
        The flown waypoint list of an ordered list of specials.
    model : FlightModel
        The time model.
    stops : Stops
        The specials' orientations.
    max_seconds : float
        The longest flight.
    clearance : ClearanceModel
        Checks the legs from and to the start.
    radius : float
        The clearance the legs keep, metres.
    floor : callable, optional
        ``floor(starts, ends)``: whether segments keep the minimum altitude.
    items : MissionItems, optional
        The mission-item limit.

    Returns
    -------
    list of list
        Each flight's waypoints.
    """
    order = np.asarray(order)
    n_special = len(order)
    single = fly(order)
    start_legs = _start_legs(fg, n_special, clearance, radius, floor)
    start_s = np.zeros(n_special)
    for i, pts in enumerate(start_legs, start=1):
        start_s[i] = leg_seconds(model, pts, np.nan, stops.heading[i], 0.0, stops.pitch[i])
    legs = _legs_of(single)  # start->s1, s1->s2, ..., sn->start
    shots = order[1:]
    between = np.array([leg_seconds(model, pts, stops.heading[a], stops.heading[b], stops.pitch[a], stops.pitch[b])
                        for pts, a, b in zip(legs[1:-1], shots[:-1], shots[1:])])
    photo_s, ground_s = model.photo_seconds, model.takeoff_landing_seconds(stops.height_m)
    alone = ground_s + 2 * start_s[1:] + photo_s
    if alone.min() > max_seconds:
        raise PlanningError(f"a flight of {max_seconds / 60:.1f} min is too short to reach the nearest shot and "
                            f"return: that takes {alone.min() / 60:.1f} min; raise --max-flight-min")
    if alone.max() > max_seconds:
        raise PlanningError(f"a flight of {max_seconds / 60:.1f} min cannot reach {int((alone > max_seconds).sum())} "
                            f"of the shots and return: the farthest alone takes {alone.max() / 60:.1f} min; raise "
                            "--max-flight-min")
    if items is not None:
        start_items = np.zeros(n_special, dtype=np.int64)
        start_items[1:] = [items.per_waypoint * (len(pts) - 1) for pts in start_legs]
        step_items = (items.per_waypoint * np.array([len(pts) - 1 for pts in legs[1:-1]], dtype=np.int64)
                      + items.step_items(stops, shots[:-1], shots[1:], [len(pts) == 2 for pts in legs[1:-1]]))
        most = RUN_ITEMS + 2 * int(start_items.max())
        if most > items.limit:
            raise PlanningError(f"a flight of at most {items.limit} mission items cannot reach every shot and return: "
                                f"the farthest alone takes {most}; raise --max-mission-items")
    limit, item_limit = max_seconds, None if items is None else items.limit
    for _attempt in range(MAX_ATTEMPTS):
        candidates = []
        for seq, btw, steps in ((shots, between, None if items is None else step_items),
                                (shots[::-1], between[::-1], None if items is None else step_items[::-1])):
            budget = None if items is None else (start_items, steps, item_limit)
            total, cuts = _best_split(seq, start_s, btw, photo_s, ground_s, limit, budget)
            if cuts is not None:
                candidates.append((total, [seq[a:b] for a, b in cuts]))
        if not candidates:
            break
        runs = min(candidates, key=lambda c: c[0])[1]
        flights, worst, worst_items = [], 0.0, 0.0
        for run in runs:
            sub = np.concatenate([[0], run])
            options = [fly(sub), fly(sub[tour(sub)])]  # as cut, reordered
            times = np.array([waypoint_times(model, w, stops)["total_s"] for w in options])
            allowed = times
            if items is not None:  # a reordered flight may come to more items than its cut
                counts = np.array([items.bound(w, stops) for w in options])
                if (counts <= items.limit).any():
                    allowed = np.where(counts <= items.limit, times, np.inf)
                else:
                    worst_items = max(worst_items, counts.min() / items.limit)
            pick = int(np.argmin(allowed))
            flights.append(options[pick])
            worst = max(worst, times[pick] / max_seconds)
        if worst <= 1.0 and worst_items <= 1.0:
            return flights
        if worst > 1.0:
            limit = limit / worst * 0.995  # the estimates were short by this much: split tighter
        if worst_items > 1.0:
            item_limit = int(item_limit / worst_items) - 1
    what = [] if not np.isfinite(max_seconds) else [f"flights of {max_seconds / 60:.1f} min"]
    what += [] if items is None else [f"flights of at most {items.limit} mission items"]
    raise PlanningError(f"could not split the tour into {' and '.join(what)}; raise "
                        + ("--max-flight-min" if items is None else "--max-flight-min or --max-mission-items"))
