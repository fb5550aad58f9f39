"""Turn between photos, hold still at them: two waypoints on each leg between photos.

With DJI's ``smoothTransition`` heading and ``gimbalEvenlyRotate`` the camera turns evenly over
a whole leg, so it is still turning as the drone passes the photo at either end, and that
turning blurs the photo as much as a few metres a second of flight would. Where two
consecutive photos differ in heading or gimbal pitch, two waypoints are put on the straight
leg between them: the first keeps the first photo's heading and pitch, the second already has
the next photo's. The camera then turns only over the middle ``share`` of the leg and holds
still on the parts either side, where the photos are taken. The waypoints lie on the leg, so
the path and its clearance are unchanged.
"""

from __future__ import annotations

import numpy as np

from coverplan.flight.route import Route
from coverplan.geometry.orientation import heading_change_deg

MIN_TURN_DEG = 1.0  # a smaller heading or pitch change between photos blurs nothing
MIN_LEG_M = 1.0  # shorter legs keep their even turn


def camera_turns(heading_a, pitch_a, heading_b, pitch_b) -> np.ndarray:
    """Whether the camera turns enough between orientation a and b for a leg joining two
    photos to get turn points (heading or pitch at least MIN_TURN_DEG apart); arrays broadcast.

    Parameters
    ----------
    heading_a, pitch_a, heading_b, pitch_b : array_like of float
        Degrees.

    Returns
    -------
    ndarray of bool
        Where the camera turns.
    """
    turn = np.abs(heading_change_deg(heading_a, heading_b))
    tilt = np.abs(np.asarray(pitch_b, float) - np.asarray(pitch_a, float))
    return (turn >= MIN_TURN_DEG) | (tilt >= MIN_TURN_DEG)


def add_turn_points(route: Route, share: float) -> Route:
    """``route`` with turn points on each leg between two photos whose orientation differs.

    Parameters
    ----------
    route : Route
        Waypoints before they are flown through (no pass speeds yet).
    share : float
        The middle share of a leg, in (0, 1], over which heading and gimbal turn; 1 adds
        nothing (they turn over the whole leg).

    Returns
    -------
    Route
        A new route with the same photos, path and parameters.
    """
    n = len(route)
    if share >= 1.0 or n < 2:
        return route
    p, h, g = route.positions, route.heading_deg, route.pitch_deg
    length = np.linalg.norm(np.diff(p, axis=0), axis=1)
    same_flight = route.flight[:-1] == route.flight[1:]
    legs = np.flatnonzero(route.shot[:-1] & route.shot[1:] & same_flight & (length >= MIN_LEG_M)
                          & camera_turns(h[:-1], g[:-1], h[1:], g[1:]))
    if not len(legs):
        return route
    edge = 0.5 * (1.0 - share)
    a, b = p[legs], p[legs + 1]
    first, second = a + edge * (b - a), b - edge * (b - a)
    # Each leg k gets its two points after row k: insert them before row k + 1.
    where = np.repeat(legs + 1, 2)
    new_p = np.empty((2 * len(legs), 3))
    new_p[0::2], new_p[1::2] = first, second
    new_h = np.column_stack([h[legs], h[legs + 1]]).ravel()
    new_g = np.column_stack([g[legs], g[legs + 1]]).ravel()
    ground = None
    if route.ground_z is not None:
        za, zb = route.ground_z[legs], route.ground_z[legs + 1]
        ground = np.insert(route.ground_z, where, np.column_stack([za + edge * (zb - za),
                                                                   zb - edge * (zb - za)]).ravel())
    kind = np.array(route.leg, dtype=object)
    return Route(np.insert(p, where, new_p, axis=0), np.insert(route.shot, where, False), np.insert(h, where, new_h),
                 np.insert(g, where, new_g), np.insert(kind, where, kind[where]).tolist(), route.camera, route.params, frame=route.frame,
                 uncovered=route.uncovered, metrics=route.metrics, extra=route.extra,
                 flight=np.insert(route.flight, where, route.flight[legs + 1].repeat(2)), ground_z=ground)
