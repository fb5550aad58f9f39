"""Roof lanes: a nadir grid over the roofs, each photo at the standoff above the highest roof near it."""

from __future__ import annotations

import numpy as np
import shapely
from scipy.spatial import cKDTree

from coverplan.shots.candidates import Candidates
from coverplan.shots.lanes import FORWARD_OVERLAP, LANE_SOURCE, SIDE_OVERLAP, Lanes, _spaced
from coverplan.shots.limits import ViewLimits

ROOF_NORMAL_Z = 0.3  # samples facing up at least this much are roof for the roof lanes


def roof_lanes(scene, samples, camera, limits: ViewLimits, distance: float, forward_overlap: float = FORWARD_OVERLAP,
               side_overlap: float = SIDE_OVERLAP) -> Lanes:
    """A nadir grid over the samples facing up, each photo ``distance`` above the highest
    sample within half a frame of it; lanes along the longer side of the roofs' footprint.

    Parameters
    ----------
    scene : Scene
        The scene.
    samples : SurfaceSamples
        The planner's samples; those whose normal has z >= ``ROOF_NORMAL_Z`` are roof.
    camera : Camera
        The camera.
    limits : ViewLimits
        The viewpoint rules.
    distance : float
        Metres above the roof.
    forward_overlap : float
        The share of a frame consecutive photos share.
    side_overlap : float
        The share of a frame neighbouring lanes share.

    Returns
    -------
    Lanes
    """
    roof = samples.normals[:, 2] >= ROOF_NORMAL_Z
    if roof.sum() < 3:
        return Lanes.empty()
    pts = samples.points[roof]
    width, height = camera.footprint(distance)
    # Heading along the lane: the frame's width sweeps across the lanes, its height along them.
    across, along = width * (1.0 - side_overlap), height * (1.0 - forward_overlap)
    rect = shapely.minimum_rotated_rectangle(shapely.multipoints(pts[:, :2]))
    corners = shapely.get_coordinates(rect)[:4]
    if len(corners) < 4:
        return Lanes.empty()
    edges = np.diff(np.vstack([corners, corners[:1]]), axis=0)
    axis = edges[int(np.argmax(np.linalg.norm(edges, axis=1)))]
    axis = axis / max(np.linalg.norm(axis), 1e-12)
    side = np.array([-axis[1], axis[0]])
    centre = pts[:, :2].mean(axis=0)
    u, v = (pts[:, :2] - centre) @ axis, (pts[:, :2] - centre) @ side
    margin = 0.25 * min(width, height)
    rows = _spaced(v.min() - margin, v.max() + margin, across)
    cols = _spaced(u.min() - margin, u.max() + margin, along)
    uu, vv = np.meshgrid(cols, rows)
    uu[1::2] = uu[1::2, ::-1]  # a lawnmower: every other lane flown back
    xy = centre + uu.reshape(-1, 1) * axis + vv.reshape(-1, 1) * side
    reach = 0.5 * min(width, height)
    over = cKDTree(pts[:, :2]).query_ball_point(xy, reach, return_length=True) > 0
    z = _highest_within(samples.points, xy, reach) + distance
    keep = over & np.isfinite(z)
    heading = np.degrees(np.arctan2(axis[0], axis[1])) % 360.0
    cands = Candidates(np.column_stack([xy, z]), np.full(len(xy), heading), np.full(len(xy), -90.0),
                       np.full(len(xy), LANE_SOURCE, dtype=np.int8))
    cands.pitch_deg = np.clip(cands.pitch_deg, *limits.pitch_range_deg)
    # One lane, flown as a lawnmower; each strip a piece of it.
    first = np.arange(len(rows)) * len(cols)
    pieces = np.column_stack([np.zeros(len(rows), dtype=np.int64), first, first + len(cols)])
    return Lanes(cands, np.zeros(len(xy), dtype=np.int64), pieces, np.zeros(1, dtype=bool)).subset(keep)


def _highest_within(points: np.ndarray, xy: np.ndarray, radius: float) -> np.ndarray:
    """(m,) the highest z of ``points`` (n, 3) within ``radius`` of each ``xy`` (m, 2)
    horizontally; -inf where none is."""
    near = cKDTree(points[:, :2]).query_ball_point(xy, radius)
    sizes = np.array([len(n) for n in near])
    out = np.full(len(xy), -np.inf)
    if sizes.sum() == 0:
        return out
    flat = np.concatenate([np.asarray(n, dtype=np.int64) for n in near if len(n)])
    starts = np.r_[0, np.cumsum(sizes[sizes > 0])[:-1]]
    out[sizes > 0] = np.maximum.reduceat(points[flat, 2], starts)
    return out
