"""Edge views: candidates that look along a wall's edge or round a corner, so the photos either side of it link."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from coverplan.shots.candidates import Candidates, thin
from coverplan.shots.limits import ViewLimits

EDGE = 3  # Candidates.source of edge_views


EDGE_TURN_DEG = 45.0  # the surface turns at least this much at an edge


def edge_views(samples, limits: ViewLimits, camera, distance: float,
               min_turn_deg: float = EDGE_TURN_DEG) -> Candidates:
    """Cameras at ``distance`` from each edge where the surface turns, looking back along
    the bisector of its two faces' normals.

    At a corner the other generators look square at one face or the other (or 30 deg off it),
    so a photo sees the face beyond the corner at 60 deg or more, where SfM rarely matches
    it: under field conditions the faces of the square, the triangle and the flush target
    came back as models of their own, joined only through such photos
    (docs/reconstruction.md). A camera on the bisector sees both faces alike.

    Parameters
    ----------
    samples : SurfaceSamples
        The planner's samples; neighbours within 1.5 spacings whose normals turn by at least
        ``min_turn_deg`` mark an edge.
    limits : ViewLimits
    camera : Camera
    distance : float
        Standoff from the edge, m.
    min_turn_deg : float

    Returns
    -------
    Candidates
        One per edge point kept by ``thin`` (source ``EDGE``).
    """
    points, normals = samples.points, samples.normals
    if len(points) < 2:
        return Candidates.empty()
    pairs = cKDTree(points).query_pairs(1.5 * samples.spacing, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    bisector = normals[i] + normals[j]
    length = np.linalg.norm(bisector, axis=1)
    # Faces turning by 150 deg or more (a thin fin, a blade) have no bisector both see.
    turns = (np.einsum("ij,ij->i", normals[i], normals[j]) <= np.cos(np.radians(min_turn_deg))) & (length > 0.5)
    i, j = i[turns], j[turns]
    ni, nj = normals[i], normals[j]
    middle = 0.5 * (points[i] + points[j])
    # The point of the edge (where the two faces' planes meet) nearest the pair's midpoint,
    # which lies inside the corner: middle + a ni + b nj on both planes.
    c = np.einsum("ij,ij->i", ni, nj)
    u = -np.einsum("ij,ij->i", ni, middle - points[i])
    v = -np.einsum("ij,ij->i", nj, middle - points[j])
    det = 1.0 - c * c
    middle = middle + ((u - c * v) / det)[:, None] * ni + ((v - c * u) / det)[:, None] * nj
    bisector = bisector[turns] / length[turns, None]
    picked = thin(middle, bisector, max(camera.footprint(distance)[1] * 0.35, samples.spacing))
    middle, bisector = middle[picked], bisector[picked]
    ok = limits.elevation_ok(bisector)
    return Candidates.looking(middle[ok] + bisector[ok] * distance, -bisector[ok], limits, source=EDGE)


EDGE_VIEW_SPACING = 1.0  # required edge views along an edge, in frame widths at the standoff


EDGE_VIEW_MIN_SHARE = 0.5  # a required edge view sees at least this share of a median candidate's samples


EDGE_VIEW_STAND_IN_DEG = 20.0  # a photo already taken this close in direction stands in for an edge view


def required_edge_views(cands: Candidates, camera, distance: float, seen: np.ndarray,
                        taken: Candidates | None = None) -> np.ndarray:
    """Indices of the edge views (``source == EDGE``) every plan with edge views takes: one
    per ``EDGE_VIEW_SPACING`` frame widths along each edge, so that each face is joined to
    the face beyond its edge by a photo that sees both alike.

    Views that see less than ``EDGE_VIEW_MIN_SHARE`` of what the median candidate sees are
    not required: above a spire's tip or a chimney's corner the faces are too small for a
    photo of them to match the others (the chapel's spire tip: 51 samples against a median
    1,148, linked to no other photo).

    Nor are views a photo already taken stands in for: one within half the spacing, looking
    within ``EDGE_VIEW_STAND_IN_DEG`` of the same way (a re-flight of a gap does not fly the
    edges the first flight photographed).

    Parameters
    ----------
    cands : Candidates
    camera : Camera
    distance : float
        The standoff, m.
    seen : (len(cands),) int
        Samples each candidate images.
    taken : Candidates, optional
        Photos already taken.

    Returns
    -------
    (k,) int
        Indices into ``cands``.
    """
    edge = np.flatnonzero((cands.source == EDGE) & (seen >= EDGE_VIEW_MIN_SHARE * np.median(seen)))
    if len(edge) == 0:
        return edge
    spacing = EDGE_VIEW_SPACING * camera.footprint(distance)[0]
    dirs = cands.view_dirs  # a property that converts every candidate's angles: once
    picked = edge[thin(cands.positions[edge], -dirs[edge], spacing)]
    if taken is not None and len(taken):
        near = cKDTree(cands.positions[picked]).sparse_distance_matrix(
            cKDTree(taken.positions), 0.5 * spacing, output_type="ndarray")
        alike = np.einsum("ij,ij->i", dirs[picked[near["i"]]], taken.view_dirs[near["j"]]) \
            >= np.cos(np.radians(EDGE_VIEW_STAND_IN_DEG))
        picked = np.delete(picked, np.unique(near["i"][alike]))
    return np.sort(picked)
