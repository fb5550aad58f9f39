"""Exact distances from points and segments to triangles, vectorised over (query, triangle) pairs.

On scenes of up to a few hundred triangles these settle the clearance questions the KD-tree
bound leaves open (``safety.ClearanceModel``) several times faster than one FCL query per
point or segment: a box test drops most (query, triangle) pairs, a plane test most of the
rest, and the exact distance runs on what remains. On bigger scenes ``NearTriangles`` pairs
each point only with the triangles near it.

A segment's distance to a triangle is 0 where it crosses it, else the least of its
endpoints' distances to the triangle and its distances to the triangle's three edges.
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.spatial import cKDTree

_TINY = 1e-300
BIG_TRIANGLE = 4.0  # x the median triangle's size: tested against every segment (NearTriangles)


def _dot(u, v):
    return np.einsum("ij,ij->i", u, v)


def point_segment_distance(p, a, b) -> np.ndarray:
    """Distance from each point ``p`` to the segment ``a``-``b`` (rows pair up).

    Parameters
    ----------
    p, a, b : (n, 3) float
        Points and segment ends.

    Returns
    -------
    (n,) float
        Distances.
    """
    d = b - a
    dd = _dot(d, d)
    t = np.clip(_dot(p - a, d) / np.maximum(dd, _TINY), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[:, None] * d), axis=1)


def point_triangle_distance(p, a, b, c) -> np.ndarray:
    """Distance from each point to the triangle ``a, b, c`` (degenerate ones: their edges).

    Parameters
    ----------
    p, a, b, c : (n, 3) float
        Points and triangle corners.

    Returns
    -------
    (n,) float
        Distances.
    """
    n = np.cross(b - a, c - a)
    nn = _dot(n, n)
    inside = ((nn > _TINY) & (_dot(np.cross(b - a, p - a), n) >= 0) & (_dot(np.cross(c - b, p - b), n) >= 0)
              & (_dot(np.cross(a - c, p - c), n) >= 0))
    plane = np.abs(_dot(p - a, n)) / np.sqrt(np.maximum(nn, _TINY))
    edges = np.minimum(np.minimum(point_segment_distance(p, a, b), point_segment_distance(p, b, c)),
                       point_segment_distance(p, c, a))
    return np.where(inside, plane, edges)


def segment_segment_distance(p1, q1, p2, q2) -> np.ndarray:
    """Least distance between segments ``p1``-``q1`` and ``p2``-``q2`` (either may be a point).

    The closest parameters of the two lines, clamped to the segments as in Ericson's
    Real-Time Collision Detection (5.1.9), parallel segments taking s = 0.

    Parameters
    ----------
    p1, q1, p2, q2 : (n, 3) float
        The two segments' ends.

    Returns
    -------
    (n,) float
        Distances.
    """
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e = _dot(d1, d1), _dot(d2, d2)
    b, c, f = _dot(d1, d2), _dot(d1, r), _dot(d2, r)
    denom = a * e - b * b
    crossing = denom > 1e-12 * a * e
    safe_a, safe_e = np.where(a > _TINY, a, 1.0), np.where(e > _TINY, e, 1.0)
    s = np.where(crossing, np.clip((b * f - c * e) / np.where(crossing, denom, 1.0), 0.0, 1.0), 0.0)
    t = (b * s + f) / safe_e
    s = np.where(t < 0, np.clip(-c / safe_a, 0.0, 1.0), np.where(t > 1, np.clip((b - c) / safe_a, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    # a segment of length 0 is its start point
    point1, point2 = a <= _TINY, e <= _TINY
    s = np.where(point1, 0.0, np.where(point2, np.clip(-c / safe_a, 0.0, 1.0), s))
    t = np.where(point2, 0.0, np.where(point1, np.clip(f / safe_e, 0.0, 1.0), t))
    return np.linalg.norm(p1 + d1 * s[:, None] - p2 - d2 * t[:, None], axis=1)


def segment_crosses_triangle(p, q, a, b, c) -> np.ndarray:
    """Whether each segment ``p``-``q`` passes through the triangle (Moeller-Trumbore); segments
    in the triangle's plane count as not crossing (their edge distances settle them).

    Parameters
    ----------
    p, q : (n, 3) float
        Segment ends.
    a, b, c : (n, 3) float
        Triangle corners.

    Returns
    -------
    (n,) bool
        Crossing segments.
    """
    d, e1, e2 = q - p, b - a, c - a
    h = np.cross(d, e2)
    det = _dot(e1, h)
    ok = np.abs(det) > 1e-12 * np.sqrt(_dot(d, d) * _dot(e1, e1) * _dot(e2, e2))
    inv = 1.0 / np.where(ok, det, 1.0)
    s = p - a
    u = inv * _dot(s, h)
    qv = np.cross(s, e1)
    v = inv * _dot(d, qv)
    t = inv * _dot(e2, qv)
    return ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= 1)


def segment_triangle_distance(p, q, a, b, c) -> np.ndarray:
    """Least distance from each segment ``p``-``q`` to the triangle ``a, b, c``.

    Parameters
    ----------
    p, q : (n, 3) float
        Segment ends.
    a, b, c : (n, 3) float
        Triangle corners.

    Returns
    -------
    (n,) float
        Distances.
    """
    d = np.minimum.reduce([point_triangle_distance(p, a, b, c), point_triangle_distance(q, a, b, c),
                           segment_segment_distance(p, q, a, b), segment_segment_distance(p, q, b, c),
                           segment_segment_distance(p, q, c, a)])
    return np.where(segment_crosses_triangle(p, q, a, b, c), 0.0, d)


def _flat_normals(triangles):
    normal = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    length = np.linalg.norm(normal, axis=1)
    flat = length > _TINY
    normal[flat] /= length[flat, None]
    return normal, flat


def _pairs_near(starts, ends, points: bool, triangles, normal, flat, i, j, radius: float) -> np.ndarray:
    """The segments ``i`` that triangle ``j`` comes closer to than ``radius`` (pairs given)."""
    a = triangles[j, 0]
    # Both ends farther than the radius on one side of the triangle's plane: clear of it.
    h1, h2 = _dot(starts[i] - a, normal[j]), _dot(ends[i] - a, normal[j])
    keep = ~flat[j] | ~(((h1 >= radius) & (h2 >= radius)) | ((h1 <= -radius) & (h2 <= -radius)))
    i, j = i[keep], j[keep]
    if len(i) == 0:
        return i
    a, b, c = triangles[j, 0], triangles[j, 1], triangles[j, 2]
    d = (point_triangle_distance(starts[i], a, b, c) if points else
         segment_triangle_distance(starts[i], ends[i], a, b, c))
    return i[d < radius]


def segments_near_triangles(starts, ends, triangles, radius: float, max_pairs: int = 2_000_000) -> np.ndarray:
    """Per segment (``starts`` == ``ends`` for points), whether some triangle comes closer than
    ``radius``.

    Parameters
    ----------
    starts, ends : (n, 3) float
        The segments.
    triangles : (m, 3, 3) float
        Triangle corners.
    radius : float
        Metres.
    max_pairs : int
        Segment-triangle pairs tested per batch.

    Returns
    -------
    (n,) bool
        Segments within ``radius`` of a triangle.
    """
    starts = np.asarray(starts, dtype=float).reshape(-1, 3)
    ends = np.asarray(ends, dtype=float).reshape(-1, 3)
    triangles = np.asarray(triangles, dtype=float).reshape(-1, 3, 3)
    near = np.zeros(len(starts), dtype=bool)
    if len(starts) == 0 or len(triangles) == 0:
        return near
    tri_lo, tri_hi = triangles.min(axis=1), triangles.max(axis=1)
    normal, flat = _flat_normals(triangles)
    points = starts is ends or np.array_equal(starts, ends)
    seg_lo = np.minimum(starts, ends) - radius
    seg_hi = np.maximum(starts, ends) + radius
    step = max(1, max_pairs // len(triangles))
    for lo in range(0, len(starts), step):
        rows = slice(lo, lo + step)
        boxes = ((seg_lo[rows, None, :] <= tri_hi[None]) & (seg_hi[rows, None, :] >= tri_lo[None])).all(axis=2)
        i, j = np.nonzero(boxes)
        near[_pairs_near(starts, ends, points, triangles, normal, flat, i + lo, j, radius)] = True
    return near


class NearTriangles:
    """``segments_near_triangles`` for thousands of triangles: a segment is tested only against
    the triangles whose bounding balls come within reach of its own (a KD-tree of their
    centres). Triangles much bigger than most (a long wall among a scan's small ones) would
    make every reach big, so they are tested against every segment, box test first.

    Parameters
    ----------
    triangles : (m, 3, 3) float
        Triangle corners.
    """

    def __init__(self, triangles):
        self.triangles = np.asarray(triangles, dtype=float).reshape(-1, 3, 3)
        centre = self.triangles.mean(axis=1)
        size = np.linalg.norm(self.triangles - centre[:, None], axis=2).max(axis=1)
        small = size <= (BIG_TRIANGLE * float(np.median(size)) if len(size) else 0.0)
        self.small = self.triangles[small]
        self.small_size = float(size[small].max()) if small.any() else 0.0
        self.tree = cKDTree(centre[small]) if small.any() else None
        self.normal, self.flat = _flat_normals(self.small)
        self.big = self.triangles[~small]

    def __call__(self, starts, ends, radius: float, chunk: int = 4096) -> np.ndarray:
        starts = np.asarray(starts, dtype=float).reshape(-1, 3)
        ends = np.asarray(ends, dtype=float).reshape(-1, 3)
        near = segments_near_triangles(starts, ends, self.big, radius)
        if self.tree is None or len(starts) == 0:
            return near
        points = starts is ends or np.array_equal(starts, ends)
        middle = (starts + ends) / 2.0
        # within radius of the segment and of a triangle's ball: within this of its centre
        reach = radius + np.linalg.norm(ends - starts, axis=1) / 2.0 + self.small_size
        for lo in range(0, len(starts), chunk):
            found = self.tree.query_ball_point(middle[lo:lo + chunk], reach[lo:lo + chunk] * (1 + 1e-9) + 1e-9,
                                               return_sorted=False)
            counts = np.fromiter(map(len, found), dtype=np.int64, count=len(found))
            j = np.fromiter(itertools.chain.from_iterable(found), dtype=np.int64, count=int(counts.sum()))
            i = np.repeat(np.arange(lo, lo + len(found)), counts)
            near[_pairs_near(starts, ends, points, self.small, self.normal, self.flat, i, j, radius)] = True
        return near
