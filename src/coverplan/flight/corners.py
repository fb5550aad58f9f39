"""Corners flown through: where the drone passes a waypoint it does not stop at, and the path it flies there."""

from __future__ import annotations

import numpy as np


def _unit(v) -> tuple[np.ndarray, np.ndarray]:
    length = np.linalg.norm(v, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.where(length[:, None] > 1e-9, v / length[:, None], 0.0)
    return u, length


def turn_angles(positions) -> np.ndarray:
    """(n,) degrees the path turns at each waypoint (0 at the ends and where a leg is empty).

    Parameters
    ----------
    positions : (n, 3) float
        Waypoints.

    Returns
    -------
    (n,) float
        Degrees.
    """
    p = np.asarray(positions, dtype=float).reshape(-1, 3)
    theta = np.zeros(len(p))
    if len(p) < 3:
        return theta
    u, _ = _unit(np.diff(p, axis=0))
    cos = np.clip(np.einsum("ij,ij->i", u[:-1], u[1:]), -1.0, 1.0)
    empty = (np.linalg.norm(u[:-1], axis=1) == 0) | (np.linalg.norm(u[1:], axis=1) == 0)
    theta[1:-1] = np.where(empty, 180.0, np.degrees(np.arccos(cos)))
    return theta


def corner_offsets(positions, damping_m) -> np.ndarray:
    """(n, 3) where the drone passes each waypoint minus the waypoint: ``d tan(theta / 4)`` into
    the turn for a turn starting ``damping_m`` (n,) before it; 0 where the damping is 0.

    Parameters
    ----------
    positions : (n, 3) float
        Waypoints.
    damping_m : (n,) float
        Metres.

    Returns
    -------
    (n, 3) float
        Metres.
    """
    p = np.asarray(positions, dtype=float).reshape(-1, 3)
    d = np.asarray(damping_m, dtype=float).reshape(-1)
    if len(p) < 3:
        return np.zeros_like(p)
    u, _ = _unit(np.diff(p, axis=0))
    inward, _ = _unit(np.concatenate([np.zeros((1, 3)), u[1:] - u[:-1], np.zeros((1, 3))]))
    quarter = np.tan(np.radians(turn_angles(p)) / 4.0)
    return inward * np.where(d > 0, d * quarter, 0.0)[:, None]


def flown_path(positions, damping_m) -> np.ndarray:
    """(m, 3) the polyline the drone flies: each waypoint flown through (``damping_m`` > 0)
    replaced by where its turn starts, where it passes the waypoint and where the turn ends
    (the arc lies within that corner of the triangle), the others kept.

    Parameters
    ----------
    positions : (n, 3) float
        Waypoints.
    damping_m : (n,) float
        Metres; 0 at stops.

    Returns
    -------
    (m, 3) float
        The flown polyline.
    """
    p = np.asarray(positions, dtype=float).reshape(-1, 3)
    d = np.asarray(damping_m, dtype=float).reshape(-1)
    if len(p) < 3:
        return p.copy()
    u, _ = _unit(np.diff(p, axis=0))
    pieces = np.stack([p - d[:, None] * np.concatenate([np.zeros((1, 3)), u]),
                       p + corner_offsets(p, d),
                       p + d[:, None] * np.concatenate([u, np.zeros((1, 3))])], axis=1)
    keep = np.ones((len(p), 3), dtype=bool)
    keep[:, [0, 2]] = (d > 0)[:, None]
    return pieces[keep]


def corner_rows(damping_m) -> np.ndarray:
    """(m,) the waypoint each point of :func:`flown_path` belongs to.

    Parameters
    ----------
    damping_m : (n,) float
        Metres, as given to ``flown_path``.

    Returns
    -------
    (m,) int
        Waypoint indices.
    """
    d = np.asarray(damping_m, dtype=float).reshape(-1)
    counts = np.where(d > 0, 3, 1) if len(d) >= 3 else np.ones(len(d), dtype=int)
    return np.repeat(np.arange(len(d)), counts)


def travel_directions(positions) -> np.ndarray:
    """(n, 3) unit direction of travel at each waypoint: along the bisector of its two legs.

    Parameters
    ----------
    positions : (n, 3) float
        Waypoints.

    Returns
    -------
    (n, 3) float
        Unit vectors; 0 where both legs are empty.
    """
    p = np.asarray(positions, dtype=float).reshape(-1, 3)
    if len(p) < 2:
        return np.zeros_like(p)
    u, _ = _unit(np.diff(p, axis=0))
    t, _ = _unit(np.concatenate([u[:1], u]) + np.concatenate([u, u[-1:]]))
    return t
