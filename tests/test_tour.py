"""The shot order: a permutation from the start, locally optimal for 2-opt and Or-opt moves,
judged by brute force over every move rather than by the solver's own bookkeeping."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from coverplan.flight.lanes import step_shape
from coverplan.flight.tour import (nearest_neighbour, plan_tour, reaim_costs, refine_turns, solve_tour, tour_length,
                                   turned_length, typical_step)


def _euclidean(points):
    return np.linalg.norm(points[:, None] - points[None], axis=2)


def _best_two_opt_gain(order, dist):
    n = len(order)
    best = 0.0
    for i in range(1, n - 1):
        for j in range(i + 1, n):
            a, b, c, d = order[i - 1], order[i], order[j], order[(j + 1) % n]
            best = min(best, dist[a, c] + dist[b, d] - dist[a, b] - dist[c, d])
    return best


def _best_move_gain(order, dist, length):
    """The best change in tour length from moving a run of ``length`` stops (not the start)
    between two other consecutive stops, either way round."""
    n = len(order)
    best = 0.0
    for i in range(1, n - length + 1):
        seg = list(order[i:i + length])
        rest = list(order[:i]) + list(order[i + length:])
        for pos in range(len(rest)):
            for piece in (seg, seg[::-1]):
                moved = rest[:pos + 1] + piece + rest[pos + 1:]
                best = min(best, tour_length(moved, dist) - tour_length(order, dist))
    return best


def test_points_on_a_circle_are_visited_around_it():
    angle = np.linspace(0.0, 2 * np.pi, 24, endpoint=False)
    shuffled = np.random.default_rng(3).permutation(24)
    points = np.column_stack([np.cos(angle), np.sin(angle)])[shuffled]
    order = solve_tour(_euclidean(points))
    around = np.argsort(np.arctan2(points[:, 1], points[:, 0]))
    start = int(np.flatnonzero(around == 0)[0])
    around = np.roll(around, -start)
    assert order[0] == 0
    assert np.array_equal(order, around) or np.array_equal(order[1:], around[1:][::-1])
    assert np.isclose(tour_length(order, _euclidean(points)), 24 * 2 * np.sin(np.pi / 24))


@settings(max_examples=40, deadline=None)
@given(st.integers(4, 40), st.integers(0, 2**31 - 1), st.booleans())
def test_tour_is_a_local_optimum(n, seed, on_grid):
    rng = np.random.default_rng(seed)
    points = rng.integers(0, 4, (n, 3)).astype(float) if on_grid else rng.random((n, 3)) * [60, 40, 20]
    dist = _euclidean(points)
    order = solve_tour(dist)
    assert order[0] == 0 and sorted(order.tolist()) == list(range(n))
    assert tour_length(order, dist) <= tour_length(nearest_neighbour(dist), dist) + 1e-9
    assert _best_two_opt_gain(order, dist) >= -1e-6
    for length in (1, 2, 3):
        assert _best_move_gain(order, dist, length) >= -1e-6


def _reversals(order, points):
    """Nodes other than the start where the tour's direction turns by more than 90 deg, counted
    with a plain loop."""
    n, count = len(order), 0
    for k in range(n):
        a, b, c = points[order[k - 1]], points[order[k]], points[order[(k + 1) % n]]
        if order[k] != 0 and np.dot(b - a, c - b) < 0:
            count += 1
    return count


@settings(max_examples=30, deadline=None)
@given(st.integers(5, 60), st.integers(0, 2**31 - 1), st.sampled_from([2.0, 12.0, 40.0]))
def test_turn_aware_tour_never_costs_more_than_the_shortest_with_its_turns(n, seed, reversal_m):
    rng = np.random.default_rng(seed)
    points = rng.random((n, 3)) * [40, 30, 15]
    dist = _euclidean(points) * rng.uniform(1.0, 1.3)  # a lattice path is longer than the line
    shortest = solve_tour(dist)
    order = refine_turns(shortest, dist, points, reversal_m)
    assert order[0] == 0 and sorted(order.tolist()) == list(range(n))
    for o in (shortest, order):  # the cost is the length plus reversal_m per reversal
        assert np.isclose(turned_length(o, dist, points, reversal_m),
                          tour_length(o, dist) + reversal_m * _reversals(o, points))
    assert turned_length(order, dist, points, reversal_m) <= turned_length(shortest, dist, points, reversal_m) + 1e-9
    assert np.array_equal(plan_tour(dist, points, reversal_m), order)
    assert np.array_equal(plan_tour(dist, points, 0.0), shortest)


def test_random_tours_turn_back_far_less_often():
    # Twenty scattered sets of 40 photos: the shortest tours turn back at about a third of
    # them; weighing a reversal as 12 m of path removes most of those turns.
    shortest = turned = 0
    for seed in range(20):
        points = np.random.default_rng(seed).random((40, 3)) * [40, 30, 15]
        dist = _euclidean(points)
        shortest += _reversals(solve_tour(dist), points)
        turned += _reversals(plan_tour(dist, points, 12.0), points)
    assert shortest >= 200
    assert turned <= 0.5 * shortest


def test_typical_step_is_the_median_distance_to_the_nearest_shot():
    # Shots 1, 2 and 4 m from their nearest along a line; the start (node 0) far off is not one.
    points = np.array([[100.0, 0, 0], [0, 0, 0], [1, 0, 0], [3, 0, 0], [7, 0, 0]])
    assert typical_step(_euclidean(points)) == 1.5  # nearest: 1, 1, 2, 4
    assert typical_step(_euclidean(points[:2])) == 0.0


def test_reaim_costs_charge_the_steps_that_turn_the_camera():
    # Node 0 is the start; 355 -> 5 deg is 10 deg across north (smooth), 5 -> 16 is not, nor a 6 deg pitch step.
    heading = np.array([0.0, 355.0, 5.0, 16.0, 5.0])
    pitch = np.array([-90.0, 0.0, 0.0, 0.0, -6.0])
    cost = reaim_costs(heading, pitch, 3.0)
    assert np.array_equal(cost, cost.T) and not cost[0].any()
    assert cost[1, 2] == 0.0 and cost[2, 3] == 3.0 and cost[1, 3] == 3.0 and cost[2, 4] == 3.0
    assert np.all(np.diag(cost) == 0.0)


def test_a_reaim_cost_flies_each_heading_as_one_lane():
    # Eight photos along a wall, alternately facing it and looking 90 deg along it: the shortest
    # tour turns the camera at every step; with the cost it flies one heading out, the other back.
    points = np.array([[-1.0, 0, 0]] + [[x, 0, 0] for x in range(8)])
    heading = np.array([0.0] + [0.0 if x % 2 == 0 else 90.0 for x in range(8)])
    pitch = np.zeros(9)
    dist = _euclidean(points)
    rough = reaim_costs(heading, pitch, 10.0)
    for cost, smooth_steps in ((None, 0), (rough, 6)):
        order = plan_tour(dist, points, 0.0, cost)
        assert sorted(order) == list(range(9)) and order[0] == 0
        smooth, _ = step_shape(points[order[1:]], heading[order[1:]], pitch[order[1:]])
        assert smooth == 100.0 * smooth_steps / 7
