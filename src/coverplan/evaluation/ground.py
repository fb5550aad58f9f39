"""The flight against the ground: its height above flat ground or terrain, and its 3D clearance from terrain."""

from __future__ import annotations

import numpy as np

from coverplan.geometry.clearance import ClearanceModel
from coverplan.shots.limits import ViewLimits


def heights_above_ground(points, limits: ViewLimits) -> tuple[np.ndarray, np.ndarray]:
    """Per segment of the polyline, its lowest and its greatest height above the ground (flat
    or terrain: at every crossing of the ground's grid).

    Parameters
    ----------
    points : (n, 3) float
        The flown polyline in the local frame.
    limits : ViewLimits
        Gives the ground: flat (``ground_z``) or terrain.

    Returns
    -------
    lowest, highest : (n - 1,) float
    """
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    if len(p) < 2:
        return np.zeros(0), np.zeros(0)
    if limits.terrain is not None:
        return limits.terrain.lowest_above(p[:-1], p[1:]), limits.terrain.highest_above(p[:-1], p[1:])
    z = p[:, 2] - limits.ground_z
    return np.minimum(z[:-1], z[1:]), np.maximum(z[:-1], z[1:])


def ground_clearance(points, scene, security: float) -> tuple[float | None, np.ndarray]:
    """Over terrain, the polyline's least distance from the ground's triangles in 3D (FCL where
    a segment may come within ``security``) and the segments that come closer than it.

    Parameters
    ----------
    points : (n, 3) float
        The flown polyline in the local frame.
    scene : Scene
        Its terrain, if any, is measured.
    security : float
        The security distance in metres.

    Returns
    -------
    clearance : float or None
        None over flat ground (there the height above it is the distance).
    near : (k,) int
        Segments closer than ``security`` to the ground.
    """
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    if scene.terrain is None or len(p) < 2:
        return None, np.zeros(0, np.int64)
    # The ground within reach of the flight, every node of the grid: exact where it matters.
    reach = security + max(scene.terrain.dx, scene.terrain.dy)
    ground = scene.terrain.mesh_within(p[:, :2].min(axis=0) - reach, p[:, :2].max(axis=0) + reach, max_cells=None)
    dist, _mesh, _exact = ClearanceModel([ground], cover_edge=scene.cover_edge(security)).polyline_clearance(p, security)
    return float(dist.min()), np.flatnonzero(dist < security - 1e-6 * max(1.0, security))
