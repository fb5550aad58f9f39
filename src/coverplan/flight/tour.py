"""Order the shots: a closed tour from the start point (index 0) through every shot and back.

Nearest neighbour, then 2-opt and Or-opt moves until neither improves, the gains of a block
of moves evaluated at once with numpy (the moves taken are those of a row-by-row search).
Deterministic: the same matrix gives the same tour. (OR-Tools' routing solver was measured
first: 8.6 s for a 500-stop tour with plain descent, and time-limited guided local search
gives run-to-run different routes.)

The shortest tour turns back on itself at a quarter of the photos, and a drone flying through
its photos must stop at each such reversal. ``plan_tour`` then runs the same moves on the
path plus a cost per turn (``turn_costs``): ``reversal_m`` metres for every turn over 90 deg,
set as a number of the tour's typical steps (``typical_step``) so that it means the same at
every GSD. Each step between two photos whose camera must turn (not a smooth step: heading
more than 10 deg or gimbal pitch more than 5 deg apart) costs ``reaim_m`` more
(``reaim_costs``), so photos that look the same way are flown one after another, in lanes.
The defaults were chosen from benchmarks/flights.py (docs/flights.md, "The order").
"""

from __future__ import annotations

import numpy as np

from coverplan.flight.lanes import smooth_step
from coverplan.flight.tour_moves import (
    EPS,
    MAX_CELLS,
    MIN_BLOCK,
    move_runs_while_improving,
    or_opt,
    reverse_while_improving,
    two_opt,
)

DEFAULT_REVERSAL_STEPS = 6.0
DEFAULT_REAIM_STEPS = 2.0
DEFAULT_LANE_STEPS = 4.0  # PlanSettings.lane_steps
_NEAR = 16  # turn-aware moves join a node to one of its 16 nearest


def tour_length(order, dist) -> float:
    """The length of the closed tour ``order``.

    Parameters
    ----------
    order : (n,) int
        Node order.
    dist : (n, n) float
        Distances.

    Returns
    -------
    float
        The sum of the tour's steps, last back to first included.
    """
    order = np.asarray(order)
    return float(dist[order, np.roll(order, -1)].sum())


def nearest_neighbour(dist) -> np.ndarray:
    """A tour from node 0 that always goes on to the nearest node not yet visited.

    Parameters
    ----------
    dist : (n, n) float
        Distances.

    Returns
    -------
    (n,) int
        Node order.
    """
    n = len(dist)
    order = [0]
    free = np.ones(n, dtype=bool)
    free[0] = False
    for _ in range(n - 1):
        row = np.where(free, dist[order[-1]], np.inf)
        k = int(np.argmin(row))
        order.append(k)
        free[k] = False
    return np.array(order)


def solve_tour(dist) -> np.ndarray:
    """A short closed tour over all nodes of the symmetric matrix ``dist``, starting at 0.

    Parameters
    ----------
    dist : (n, n) float
        Symmetric distances.

    Returns
    -------
    (n,) int
        Node order.
    """
    dist = np.asarray(dist, dtype=float)
    n = len(dist)
    if n <= 3:
        return np.arange(n)
    order = nearest_neighbour(dist)
    while True:
        order, a = two_opt(order, dist)
        order, b = or_opt(order, dist)
        if not (a or b):
            return order


def turn_costs(positions, a, b, c, reversal_m: float) -> np.ndarray:
    """The cost of flying a -> b -> c at b, in metres of path: ``reversal_m`` where the
    direction turns by more than 90 deg (the drone must stop there). Index arrays broadcast;
    a turn at node 0 (take-off and landing) or over a step of no length costs nothing. Only
    the sign of (b - a) . (c - b) matters, so nothing is normalised.

    Parameters
    ----------
    positions : (n, 3) float
        Node positions.
    a, b, c : array_like of int
        Node indices.
    reversal_m : float
        Metres a reversal costs.

    Returns
    -------
    ndarray of float
        Metres.
    """
    x, y, z = np.asarray(positions).T  # per axis: 3x faster than einsum on the moves' small blocks
    back = (x[b] - x[a]) * (x[c] - x[b]) + (y[b] - y[a]) * (y[c] - y[b]) + (z[b] - z[a]) * (z[c] - z[b]) < 0.0
    return np.where(back & (np.asarray(b) != 0), reversal_m, 0.0)


def turned_length(order, dist, positions, reversal_m: float) -> float:
    """``tour_length`` plus the ``turn_costs`` at every node of the closed tour.

    Parameters
    ----------
    order : (n,) int
        A closed tour.
    dist : (n, n) float
        Distances.
    positions : (n, 3) float
        Node positions.
    reversal_m : float
        Metres a reversal costs.

    Returns
    -------
    float
        Metres.
    """
    t = np.asarray(order)
    turns = turn_costs(positions, np.roll(t, 1), t, np.roll(t, -1), reversal_m)
    return tour_length(t, dist) + float(turns.sum())


def _near(dist, k: int) -> np.ndarray:
    """(n, k) each node's k nearest other nodes by ``dist``."""
    n = len(dist)
    k = min(k, n - 1)
    d = dist + np.diag(np.full(n, np.inf))
    near = np.argpartition(d, k - 1, axis=1)[:, :k]
    return np.take_along_axis(near, np.argsort(np.take_along_axis(d, near, axis=1), axis=1), axis=1)


def _two_opt_turns(t, dist, positions, near, reversal_m) -> tuple[np.ndarray, bool]:
    """2-opt on length plus turn costs: reversing t[i..k] changes the two edges at its ends and
    the turns at the four nodes around them (the turns inside keep their angles). Only
    reversals whose new edge joins t[i - 1] to one of its ``near`` nodes are tried."""
    n = len(t)

    def cost(a, b, c):
        return turn_costs(positions, a, b, c, reversal_m)

    def moves(t, lo, hi):
        where = np.empty(n, dtype=int)
        where[t] = np.arange(n)
        turn = cost(np.roll(t, 1), t, np.roll(t, -1))  # the tour's turn at each position
        i = np.arange(lo, hi)[:, None]
        a0, a, b, b1 = t[(i - 2) % n], t[i - 1], t[i], t[(i + 1) % n]
        k = where[near[a[:, 0]]]
        c0, c, d, d1 = t[(k - 1) % n], t[k], t[(k + 1) % n], t[(k + 2) % n]
        old = dist[a, b] + dist[c, d] + turn[i - 1] + turn[i] + turn[k] + turn[(k + 1) % n]
        new = dist[a, c] + dist[b, d] + cost(a0, a, c) + cost(a, c, c0) + cost(b1, b, d) + cost(b, d, d1)
        delta = np.where((k <= i) | (k - i >= n - 2), np.inf, new - old)
        best = np.argmin(delta, axis=1)
        rows = np.arange(len(delta))
        good = delta[rows, best] < -EPS
        return k[rows, best], good, good

    return reverse_while_improving(t, moves, max(MIN_BLOCK, MAX_CELLS // near.shape[1]))


def _or_opt_turns(t, dist, positions, near, reversal_m, max_segment: int = 3) -> tuple[np.ndarray, bool]:
    """Or-opt on length plus turn costs. A run t[i..i+L-1] leaves the turns at its neighbours
    and its own ends; put between X and Y it makes the turns at X, its ends and Y. It is tried
    next to the ``near`` nodes of its ends; places that touch its old neighbours are left to
    2-opt (their turns would need the tour after the removal)."""
    n = len(t)

    def cost(a, b, c):
        return turn_costs(positions, a, b, c, reversal_m)

    def moves(t, lo, hi, length):
        where = np.empty(n, dtype=int)
        where[t] = np.arange(n)
        turn = cost(np.roll(t, 1), t, np.roll(t, -1))  # the tour's turn at each position
        i = np.arange(lo, hi)
        f, last = t[i], t[i + length - 1]
        f2, l0 = t[i + 1] if length > 1 else None, t[i + length - 2] if length > 1 else None
        a, p, nx, b = t[(i - 2) % n], t[i - 1], t[(i + length) % n], t[(i + length + 1) % n]
        ends = turn[i] + turn[i + length - 1] if length > 1 else turn[i]
        saved = (dist[p, f] + dist[last, nx] - dist[p, nx] + turn[i - 1] + turn[(i + length) % n] + ends
                 - cost(a, p, nx) - cost(p, nx, b))
        ends_near = np.concatenate([where[near[f]], where[near[last]]], axis=1)
        k = np.concatenate([ends_near, ends_near - 1], axis=1) % n  # edge k: t[k] -> t[k + 1]
        w, x, y, z = t[(k - 1) % n], t[k], t[(k + 1) % n], t[(k + 2) % n]
        F, Lst = f[:, None], last[:, None]
        base = dist[x, y] + turn[k] + turn[(k + 1) % n]
        if length > 1:
            F2, L0 = f2[:, None], l0[:, None]
            fwd = (dist[x, F] + dist[Lst, y] + cost(w, x, F) + cost(x, F, F2) + cost(L0, Lst, y) + cost(Lst, y, z)
                   - base)
            rev = (dist[x, Lst] + dist[F, y] + cost(w, x, Lst) + cost(x, Lst, L0) + cost(F2, F, y) + cost(F, y, z)
                   - base)
        else:
            fwd = dist[x, F] + dist[F, y] + cost(w, x, F) + cost(x, F, y) + cost(F, y, z) - base
            rev = fwd
        both = np.minimum(fwd, rev)
        # edges the run touches or whose turns involve its old neighbours
        ii = i[:, None]
        both[((k >= ii - 3) & (k <= ii + length)) | ((ii <= 3) & (k >= n - 2))] = np.inf
        best = np.argmin(both, axis=1)
        rows = np.arange(len(i))
        return k[rows, best], both[rows, best] < saved - EPS, fwd[rows, best] <= rev[rows, best]

    # the run's next stop (its turn is judged) is inside the tour: it ends at n - 2 at the latest
    return move_runs_while_improving(t, moves, max(MIN_BLOCK, MAX_CELLS // (4 * near.shape[1])), max_segment,
                                      n - 1)


def refine_turns(order, dist, positions, reversal_m: float) -> np.ndarray:
    """A tour that trades path for turns: 2-opt and Or-opt on ``dist`` plus ``turn_costs``
    until neither improves, starting from ``order`` (node 0 stays first).

    Parameters
    ----------
    order : (n,) int
        A closed tour starting at node 0.
    dist : (n, n) float
        Symmetric path lengths between the nodes.
    positions : (n, 3) float
        Where the nodes are; the turn at a node is judged on the straight lines to its
        neighbours in the tour.
    reversal_m : float
        Metres of path a reversal (a turn over 90 deg) and a full turn back are worth.

    Returns
    -------
    (n,) int
        Node order, node 0 first.
    """
    positions = np.asarray(positions, dtype=float)
    dist = np.asarray(dist, dtype=float)
    t = np.array(order)
    if len(t) <= 4 or reversal_m <= 0:
        return t
    near = _near(dist, _NEAR)
    while True:
        t, a = _two_opt_turns(t, dist, positions, near, reversal_m)
        t, b = _or_opt_turns(t, dist, positions, near, reversal_m)
        if not (a or b):
            return t


def typical_step(dist) -> float:
    """The median distance from a shot (nodes 1..n-1 of ``dist``) to its nearest shot; 0 for
    fewer than two shots.

    Parameters
    ----------
    dist : (n, n) float
        Distances, node 0 the start.

    Returns
    -------
    float
        Metres.
    """
    d = np.asarray(dist, dtype=float)[1:, 1:]
    if len(d) < 2:
        return 0.0
    return float(np.median((d + np.diag(np.full(len(d), np.inf))).min(axis=1)))


def reaim_costs(heading_deg, pitch_deg, reaim_m: float) -> np.ndarray:
    """(n, n) ``reaim_m`` between two nodes whose step would not be smooth (heading more than
    10 deg or gimbal pitch more than 5 deg apart, flight/lanes.py), else 0; node 0 (the start)
    costs nothing.

    Parameters
    ----------
    heading_deg, pitch_deg : (n,) float
        Each node's orientation.
    reaim_m : float
        Metres a rough step costs.

    Returns
    -------
    (n, n) float
        Metres.
    """
    heading = np.asarray(heading_deg, dtype=float)
    pitch = np.asarray(pitch_deg, dtype=float)
    rough = ~smooth_step(heading[:, None], pitch[:, None], heading[None, :], pitch[None, :])
    rough[0, :] = rough[:, 0] = False
    return np.where(rough, float(reaim_m), 0.0)


def lane_costs(pairs: np.ndarray, shots: np.ndarray, lane_m: float) -> np.ndarray:
    """(n + 1, n + 1) ``lane_m`` between two nodes that are not photos flown one after the other
    in a lane, else 0; node 0 (the start) costs nothing. The tour then flies every lane end to
    end and enters and leaves lanes only at their ends, unless that costs more than ``lane_m``
    of path.

    Parameters
    ----------
    pairs : (k, 2) int
        Candidate indices of the lanes' consecutive photos (``lane_selection.ring_pairs``).
    shots : (n,) int
        The candidate index of each shot (node k + 1).
    lane_m : float
        Metres of path that breaking a lane is worth.

    Returns
    -------
    (n + 1, n + 1) float
        Metres.
    """
    shots = np.asarray(shots, dtype=np.int64)
    n = len(shots) + 1
    cost = np.full((n, n), float(lane_m))
    cost[0, :] = cost[:, 0] = 0.0
    node = np.full(int(max(shots.max(initial=-1), np.max(pairs, initial=-1))) + 1, -1, dtype=np.int64)
    node[shots] = np.arange(1, n)
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    a, b = node[pairs[:, 0]], node[pairs[:, 1]]
    ok = (a > 0) & (b > 0)
    cost[a[ok], b[ok]] = cost[b[ok], a[ok]] = 0.0
    np.fill_diagonal(cost, 0.0)
    return cost


def plan_tour(dist, positions, reversal_m: float, step_cost=None) -> np.ndarray:
    """``solve_tour`` on ``dist`` (plus ``step_cost``), then ``refine_turns`` with
    ``reversal_m`` (none at 0).

    Parameters
    ----------
    dist : (n, n) float
        Symmetric path lengths between the start (node 0) and the shots.
    positions : (n, 3) float
        The nodes' positions.
    reversal_m : float
        Metres of path one reversal is worth.
    step_cost : (n, n) float, optional
        Metres added to each step's path (``reaim_costs``).

    Returns
    -------
    (n,) int
        The closed tour, starting at node 0.
    """
    if step_cost is not None:
        dist = np.asarray(dist, dtype=float) + step_cost
    order = solve_tour(dist)
    return refine_turns(order, dist, positions, reversal_m) if reversal_m > 0 else order
