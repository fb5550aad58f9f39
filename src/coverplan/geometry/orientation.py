"""Heading / gimbal pitch <-> view direction, as docs/design.md fixes them.

Heading: degrees clockwise from +y (north) in [0, 360). Pitch: degrees, 0 horizontal,
-90 straight down, positive up. All functions take and return arrays.
"""

from __future__ import annotations

import numpy as np


def view_direction(heading_deg, pitch_deg) -> np.ndarray:
    """Unit view vectors (..., 3) for headings and pitches in degrees.

    Parameters
    ----------
    heading_deg : array_like of float
        Clockwise from +y (north).
    pitch_deg : array_like of float
        Up positive, down negative.

    Returns
    -------
    (..., 3) float
        Unit vectors.
    """
    h = np.radians(np.asarray(heading_deg, dtype=float))
    p = np.radians(np.asarray(pitch_deg, dtype=float))
    cp = np.cos(p)
    return np.stack([cp * np.sin(h), cp * np.cos(h), np.sin(p)], axis=-1)


def heading_pitch(view_dir) -> tuple[np.ndarray, np.ndarray]:
    """Heading in [0, 360) and pitch in [-90, 90] of view vectors (..., 3).

    Straight up or down has no heading of its own; 0 is returned there.

    Parameters
    ----------
    view_dir : (..., 3) float
        View vectors (need not be unit).

    Returns
    -------
    heading, pitch : (...,) float
        Degrees.
    """
    d = np.asarray(view_dir, dtype=float)
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    pitch = np.degrees(np.arcsin(np.clip(d[..., 2], -1.0, 1.0)))
    horizontal = np.hypot(d[..., 0], d[..., 1])
    heading = np.where(horizontal > 1e-9, np.degrees(np.arctan2(d[..., 0], d[..., 1])), 0.0)
    return np.mod(heading, 360.0), pitch


def camera_axes(heading_deg, pitch_deg) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(right, up, forward) unit vectors of cameras; image up = right x forward.

    Parameters
    ----------
    heading_deg, pitch_deg : (n,) float
        Degrees.

    Returns
    -------
    right, up, forward : (n, 3) float
        Unit vectors.
    """
    h = np.radians(np.asarray(heading_deg, dtype=float))
    forward = view_direction(heading_deg, pitch_deg)
    right = np.stack([np.cos(h), -np.sin(h), np.zeros_like(h)], axis=-1)
    up = np.cross(right, forward)
    return right, up, forward


def angle_between_deg(a, b) -> np.ndarray:
    """Angle in degrees between vectors a and b (broadcasting over leading axes).

    Parameters
    ----------
    a, b : (..., 3) float
        Vectors (need not be unit).

    Returns
    -------
    (...,) float
        Degrees in [0, 180].
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    na = np.linalg.norm(a, axis=-1)
    nb = np.linalg.norm(b, axis=-1)
    cos = np.einsum("...i,...i->...", a, b) / np.maximum(na * nb, 1e-300)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def heading_change_deg(heading_a, heading_b) -> np.ndarray:
    """The turn from heading a to heading b in degrees, in [-180, 180) (positive clockwise),
    the short way across north; arrays broadcast.

    Parameters
    ----------
    heading_a, heading_b : array_like of float
        Degrees.

    Returns
    -------
    ndarray of float
        Degrees.
    """
    return (np.asarray(heading_b, dtype=float) - np.asarray(heading_a, dtype=float) + 180.0) % 360.0 - 180.0
