"""How fast a drone may fly each leg, and how long a leg takes between given end speeds."""

from __future__ import annotations

import numpy as np


def leg_top_speeds(model, positions, heading_deg, pitch_deg, shot, photo_interval_s: float) -> np.ndarray:
    """(n - 1,) the highest speed on each leg: within the cruise speed horizontally and the
    climb / descent rate vertically, no faster than the heading and gimbal turn over it, and
    between two photos at least ``photo_interval_s`` from one to the next.

    Parameters
    ----------
    model : FlightModel
        The time model.
    positions : (n, 3) float
        Waypoints.
    heading_deg, pitch_deg : (n,) float
        Orientations.
    shot : (n,) bool
        Which take a photo.
    photo_interval_s : float
        The shortest time between photos.

    Returns
    -------
    (n - 1,) float
        m/s.
    """
    p = np.asarray(positions, dtype=float).reshape(-1, 3)
    length = np.linalg.norm(np.diff(p, axis=0), axis=1)
    top = model.top_speeds(p[:-1], p[1:])
    turn = model.rotation_seconds(heading_deg, pitch_deg)
    with np.errstate(divide="ignore", invalid="ignore"):
        top = np.minimum(top, np.where(turn > 0, length / turn, np.inf))
    rows = np.flatnonzero(shot)
    if len(rows) > 1:
        arc = np.concatenate([[0.0], np.cumsum(length)])
        stretch = np.searchsorted(rows, np.arange(len(length)), side="right") - 1
        inside = (stretch >= 0) & (stretch < len(rows) - 1)
        between = np.zeros(len(length))
        s = stretch[inside]
        between[inside] = arc[rows[s + 1]] - arc[rows[s]]
        top = np.where(inside, np.minimum(top, between / photo_interval_s), top)
    return top


def reachable_speeds(bound, length, acceleration: float) -> np.ndarray:
    """(n,) the highest speeds within ``bound`` (n,) that accelerate and brake within
    ``acceleration`` over the legs ``length`` (n - 1,): ``v_k**2 <= b_j**2 + 2 a abs(s_k - s_j)`` for all j,
    as two running minima.

    Parameters
    ----------
    bound : (n,) float
        Speed bounds at the waypoints, m/s.
    length : (n - 1,) float
        Leg lengths, metres.
    acceleration : float
        m/s².

    Returns
    -------
    (n,) float
        m/s.
    """
    b2 = np.asarray(bound, dtype=float) ** 2
    s = np.concatenate([[0.0], np.cumsum(length)])
    two_a = 2.0 * acceleration
    forward = two_a * s + np.minimum.accumulate(b2 - two_a * s)
    backward = -two_a * s + np.minimum.accumulate((b2 + two_a * s)[::-1])[::-1]
    return np.sqrt(np.clip(np.minimum(forward, backward), 0.0, None))


def trapezoid_seconds(length, entry, exit_, top, acceleration: float) -> np.ndarray:
    """(m,) time over legs of ``length`` from speed ``entry`` to ``exit_`` with at most ``top``,
    speeding up and braking at ``acceleration`` (the end speeds must be reachable).

    Parameters
    ----------
    length : (m,) float
        Metres.
    entry, exit_ : (m,) float
        m/s.
    top : (m,) float
        m/s.
    acceleration : float
        m/s².

    Returns
    -------
    (m,) float
        Seconds.
    """
    L, u, w = (np.asarray(x, dtype=float) for x in (length, entry, exit_))
    V = np.maximum(np.asarray(top, dtype=float), np.maximum(u, w))
    a = acceleration
    ramps = (2.0 * V ** 2 - u ** 2 - w ** 2) / (2.0 * a)
    with np.errstate(divide="ignore", invalid="ignore"):
        cruise = (V - u) / a + (V - w) / a + (L - ramps) / V
        peak = np.sqrt(np.clip(a * L + 0.5 * (u ** 2 + w ** 2), 0.0, None))
        short = (2.0 * peak - u - w) / a
    return np.where(L <= 0, 0.0, np.where(ramps <= L, cruise, short))


def _flown_legs(model, length, speed, top, heading_deg, pitch_deg) -> np.ndarray:
    """(n - 1,) each leg's time between its end speeds ``speed`` (n,), no faster than ``top``
    and no shorter than its heading and gimbal turns."""
    legs = trapezoid_seconds(length, speed[:-1], speed[1:], top, model.acceleration)
    return np.maximum(legs, model.rotation_seconds(heading_deg, pitch_deg))


def leg_speeds(route, cruise_speed: float) -> np.ndarray:
    """(n,) the speed each waypoint's exported leg to the next is flown at: the cruise speed,
    slowed to the pass speed of either end that is flown through (DJI's ``waypointSpeed``, a
    ``DO_CHANGE_SPEED`` before a MAVLink waypoint). The last waypoint keeps the cruise speed.

    Parameters
    ----------
    route : Route
        The route.
    cruise_speed : float
        m/s.

    Returns
    -------
    (n,) float
        m/s.
    """
    n = len(route.positions)
    out = np.full(n, float(cruise_speed))
    if route.pass_speed is None or n < 2:
        return out
    v = np.where(route.pass_speed > 0, route.pass_speed, np.inf)
    out[:-1] = np.minimum(out[:-1], np.minimum(v[:-1], v[1:]))
    return out


def route_leg_seconds(route, model, photo_interval_s: float) -> np.ndarray:
    """(n - 1,) each leg's time as the route is flown: through its recorded pass speeds (from
    rest to rest where it stops), no faster than :func:`leg_top_speeds`; 0 between battery
    flights.

    Parameters
    ----------
    route : Route
        The route.
    model : FlightModel
        The time model.
    photo_interval_s : float
        The shortest time between photos.

    Returns
    -------
    (n - 1,) float
        Seconds.
    """
    n = len(route.positions)
    legs = np.zeros(max(n - 1, 0))
    speed = route.pass_speed if route.pass_speed is not None else np.zeros(n)
    for rows in route.flight_rows():
        if len(rows) < 2:
            continue
        p = route.positions[rows]
        top = leg_top_speeds(model, p, route.heading_deg[rows], route.pitch_deg[rows], route.shot[rows],
                             photo_interval_s)
        legs[rows[:-1]] = _flown_legs(model, np.linalg.norm(np.diff(p, axis=0), axis=1), speed[rows], top,
                                      route.heading_deg[rows], route.pitch_deg[rows])
    return legs
