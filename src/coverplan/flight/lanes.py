"""How a flight reads to a pilot: smooth steps and reversals between consecutive photos.

A flight in lanes runs along a façade or round the building with a steady heading; a
scribble turns the camera and turns back at every photo. Two figures tell them apart:

- a *smooth step* joins two consecutive photos whose heading differs by at most 10 deg and
  whose gimbal pitch by at most 5 deg;
- a *reversal* is a photo where the direction of travel turns by more than 90 deg (the step
  to it and the step from it point in opposite half-spaces), to within ``REVERSAL_TOLERANCE_DEG`` of
  tolerance: a lawnmower's square turn is not one.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from coverplan.geometry.orientation import heading_change_deg

SMOOTH_HEADING_DEG = 10.0
SMOOTH_PITCH_DEG = 5.0
REVERSAL_TOLERANCE_DEG = 1.0


def smooth_step(heading_a, pitch_a, heading_b, pitch_b) -> np.ndarray:
    """Whether a step from orientation a to b is smooth (heading within 10 deg across north,
    gimbal pitch within 5 deg); arrays broadcast.

    Parameters
    ----------
    heading_a, pitch_a, heading_b, pitch_b : array_like of float
        Degrees.

    Returns
    -------
    ndarray of bool
        Smooth steps.
    """
    turn = np.abs(heading_change_deg(heading_a, heading_b))
    tilt = np.abs(np.asarray(pitch_b, float) - np.asarray(pitch_a, float))
    return (turn <= SMOOTH_HEADING_DEG) & (tilt <= SMOOTH_PITCH_DEG)


def step_shape(positions, heading_deg, pitch_deg) -> tuple[float, float]:
    """Smooth steps and reversals of photos taken in this order.

    Parameters
    ----------
    positions : (n, 3) float
        Photo positions in flight order.
    heading_deg, pitch_deg : (n,) float
        Their headings and gimbal pitches.

    Returns
    -------
    smooth_pct : float
        Percent of the n - 1 steps that are smooth (100 for fewer than two photos).
    reversals_per_100 : float
        Reversals per 100 photos; steps of no length are skipped.
    """
    positions = np.asarray(positions, float).reshape(-1, 3)
    n = len(positions)
    if n < 2:
        return 100.0, 0.0
    heading, pitch = np.asarray(heading_deg, float), np.asarray(pitch_deg, float)
    smooth = 100.0 * float(np.mean(smooth_step(heading[:-1], pitch[:-1], heading[1:], pitch[1:])))
    step = np.diff(positions, axis=0)
    step = step[np.linalg.norm(step, axis=1) > 1e-6]
    norm = np.linalg.norm(step, axis=1)
    back = np.einsum("ij,ij->i", step[:-1], step[1:]) < -np.sin(np.radians(REVERSAL_TOLERANCE_DEG)) * norm[:-1] * norm[1:]
    return smooth, 100.0 * float(back.sum()) / n


def route_step_shape(route) -> tuple[float, float]:
    """``step_shape`` of a Route's photos in flight order (waypoints without a photo skipped).

    Parameters
    ----------
    route : Route
        The route.

    Returns
    -------
    smooth_pct : float
        Smooth steps, percent.
    reversals_per_100 : float
        Reversals per 100 photos.
    """
    rows = route.shots
    return step_shape(route.positions[rows], route.heading_deg[rows], route.pitch_deg[rows])


def smooth_ceiling(heading_deg, pitch_deg) -> float:
    """The most smooth steps any order of these photos could have, in percent: an upper bound.

    Photos join into groups through smooth steps (a chain of them may drift past 10 deg); an
    order steps from one group to another at least once per group after the first, and that
    step is not smooth. So with n photos in c groups at most n - c of the n - 1 steps are.

    Parameters
    ----------
    heading_deg, pitch_deg : (n,) float
        The photos' headings and gimbal pitches, in any order.

    Returns
    -------
    float
        100 (n - c) / (n - 1); 100 for fewer than two photos.
    """
    heading, pitch = np.asarray(heading_deg, float), np.asarray(pitch_deg, float)
    n = len(heading)
    if n < 2:
        return 100.0
    joined = smooth_step(heading[:, None], pitch[:, None], heading[None], pitch[None])
    groups, _ = connected_components(sp.csr_matrix(joined), directed=False)
    return 100.0 * (n - groups) / (n - 1)
