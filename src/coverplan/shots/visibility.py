"""Which cameras image which surface points: frustum, occlusion, incidence and range.

A camera at ``c`` with axes (right, up, forward) images point ``p`` with normal ``n`` when
1. ``p`` is inside the frustum (both half field-of-view angles),
2. the segment ``p -> c`` hits no mesh,
3. the angle between ``n`` and ``c - p`` is at most ``max_incidence_deg``,
4. ``|c - p| <= max_range`` (the range at which the GSD equals the target).
``shrink`` tightens 1, 3 and 4 by a fraction, so a plan made with it still holds between
its samples.
"""

from __future__ import annotations

import itertools

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from coverplan.geometry.orientation import camera_axes
from coverplan.runs import run_offsets
from coverplan.shots.reachability import tangent_frames


def imaging_pairs(positions, headings, pitches, camera, points, normals, rays, *,
                  max_range: float, max_incidence_deg: float, shrink: float = 0.0, ball_m: float = 0.0,
                  offset: float = 1e-3, cameras_per_chunk: int = 64, progress=None, point_tree=None):
    """All (camera, point) pairs where the camera images the point, with their ranges.

    ``ball_m`` > 0 asks more: the frustum and range tests must hold for every point within
    ``ball_m`` of the point, and the incidence test with the angle such a move can add, so
    that a view found for one sample also holds for the surface around it.

    Each camera's candidate points come from a KD-tree ball query around its frustum
    (``point_tree``, a cKDTree of ``points``, spares building it again); the frustum, range
    and incidence tests then run on the flat list of (camera, point) pairs, cameras taken in
    spatially compact chunks, before the surviving pairs are ray cast.
    Returns ``(camera_index, point_index, range)`` arrays.

    Parameters
    ----------
    positions : (c, 3) float
        Camera centres.
    headings, pitches : (c,) float
        Degrees.
    camera : Camera
        The camera.
    points, normals : (n, 3) float
        Samples.
    rays : RayCaster
        Occlusion tests.
    max_range : float
        Metres.
    max_incidence_deg : float
        Degrees.
    shrink : float
        The frame's share cut off on each side.
    ball_m : float
        Metres round each point the tests must hold.
    offset : float
        Metres the occlusion ray starts off the surface.
    cameras_per_chunk : int
        Cameras per batch.
    progress : callable, optional
        ``update(n)`` of a progress bar.
    point_tree : scipy.spatial.cKDTree, optional
        Over ``points``.

    Returns
    -------
    cam, pt : (m,) int
        Camera and point of each pair.
    range : (m,) float
        Metres.
    """
    chunks = [c[:3] for c in _imaged_chunks(positions, headings, pitches, camera, points, normals, rays,
                                            max_range=max_range, max_incidence_deg=max_incidence_deg, shrink=shrink,
                                            ball_m=ball_m, offset=offset, cameras_per_chunk=cameras_per_chunk,
                                            progress=progress, point_tree=point_tree)]
    if not chunks:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    return tuple(np.concatenate(a) for a in zip(*chunks))


def imaging_pairs_firm(positions, headings, pitches, camera, points, normals, rays, *,
                       max_range: float, max_incidence_deg: float, firm_shrink: float, firm_ball_m: float,
                       offset: float = 1e-3, point_tree=None):
    """``imaging_pairs`` (no shrink) plus, per pair, whether the view also holds with
    ``firm_shrink`` off the frustum, range and incidence for all points within ``firm_ball_m``:
    ``(camera_index, point_index, range, firm)``.

    Parameters
    ----------
    positions : (c, 3) float
        Camera centres.
    headings, pitches : (c,) float
        Degrees.
    camera : Camera
        The camera.
    points, normals : (n, 3) float
        Samples.
    rays : RayCaster
        Occlusion tests.
    max_range : float
        Metres.
    max_incidence_deg : float
        Degrees.
    firm_shrink : float
        The frame's share a firm view keeps spare.
    firm_ball_m : float
        Metres round the point a firm view holds.
    offset : float
        Metres the occlusion ray starts off the surface.
    point_tree : scipy.spatial.cKDTree, optional
        Over ``points``.

    Returns
    -------
    cam, pt : (m,) int
        Camera and point of each pair.
    range : (m,) float
        Metres.
    firm : (m,) bool
        Whether the view is firm.
    """
    keep = 1.0 - firm_shrink
    tan_h, tan_v = camera.tan_half_hfov * keep, camera.tan_half_vfov * keep
    out = []
    for i, j, d, x, y, z, towards in _imaged_chunks(
            positions, headings, pitches, camera, points, normals, rays, max_range=max_range,
            max_incidence_deg=max_incidence_deg, shrink=0.0, ball_m=0.0, offset=offset, point_tree=point_tree):
        firm = in_view(x, y, z, d, towards, tan_h, tan_v, keep * max_range, keep * max_incidence_deg, firm_ball_m)
        out.append((i, j, d, firm))
    if not out:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0), np.zeros(0, bool)
    return tuple(np.concatenate(a) for a in zip(*out))


def _imaged_chunks(positions, headings, pitches, camera, points, normals, rays, *, max_range, max_incidence_deg,
                   shrink, ball_m, offset, cameras_per_chunk: int = 64, progress=None, point_tree=None):
    """Per chunk of cameras, the imaged pairs: camera and point indices, range, the point's
    camera-frame x, y, z and normal . (camera - point)."""
    positions = np.asarray(positions, dtype=float).reshape(-1, 3)
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    normals = np.asarray(normals, dtype=float).reshape(-1, 3)
    if len(positions) == 0 or len(points) == 0:
        return
    right, up, forward = camera_axes(headings, pitches)
    right, up, forward = (np.atleast_2d(a) for a in (right, up, forward))
    frames = np.stack([right, up, forward], axis=2)  # v @ frames[c]: v in camera c's (x, y, z)
    keep = 1.0 - shrink
    tan_h, tan_v = camera.tan_half_hfov * keep, camera.tan_half_vfov * keep
    reach = max_range * keep
    point_tree = cKDTree(points) if point_tree is None else point_tree
    # The smallest ball around a frustum's part within range passes through the camera and
    # the rim of the spherical cap whose half-angle is the image corner's angle off the axis.
    corner_cos = 1.0 / np.sqrt(1.0 + tan_h ** 2 + tan_v ** 2)
    ball = reach / (2.0 * corner_cos) if corner_cos >= 0.5 else reach
    centres = positions + forward * ball if corner_cos >= 0.5 else positions
    # One ball per camera: a ball around a chunk of cameras held 7x the pairs (ring prism).
    order = _spatial_order(centres, ball)
    for lo in range(0, len(order), cameras_per_chunk):
        cams = order[lo:lo + cameras_per_chunk]
        near = point_tree.query_ball_point(centres[cams], ball * (1 + 1e-9), return_sorted=False)
        counts = np.fromiter(map(len, near), dtype=np.int64, count=len(cams))
        j = np.fromiter(itertools.chain.from_iterable(near), dtype=np.int64, count=int(counts.sum()))
        i = np.repeat(cams, counts)
        # Each camera's points are one run: one small matrix product per camera rotates them
        # into its frame, 1.3x faster than gathering the camera's axes for every pair.
        v = points[j]
        local = np.empty_like(v)
        ends = np.cumsum(counts)
        for c, s, e in zip(cams[counts > 0], (ends - counts)[counts > 0], ends[counts > 0]):
            v[s:e] -= positions[c]
            np.matmul(v[s:e], frames[c], out=local[s:e])
        x, y, z = local[:, 0], local[:, 1], local[:, 2]
        dist = np.sqrt(x * x + y * y + z * z)
        towards = -np.einsum("ij,ij->i", v, normals[j])
        k = np.flatnonzero(in_view(x, y, z, dist, towards, tan_h, tan_v, reach, max_incidence_deg * keep, ball_m))
        towards = towards[k]
        if len(k):
            clear = ~rays.segments_blocked(points[j[k]] + normals[j[k]] * offset, positions[i[k]])
            k, towards = k[clear], towards[clear]
        yield i[k], j[k], dist[k], x[k], y[k], z[k], towards
        if progress is not None:
            progress(len(cams))


def clear_around(rays, points, normals, cameras, radius: float, skip: float) -> np.ndarray:
    """Per (point, camera): whether the camera also sees past whatever stands between from
    the four points ``radius`` off the point in its tangent plane. Their segments start
    ``skip`` out, so the surface beside the point (a concave corner) does not count: that
    is the point's own ray's business.

    Parameters
    ----------
    rays : RayCaster
        Occlusion tests.
    points, normals : (m, 3) float
        The point of each pair.
    cameras : (m, 3) float
        The camera of each pair.
    radius : float
        Metres.
    skip : float
        The share of each segment skipped at its start.

    Returns
    -------
    (m,) bool
        Clear pairs.
    """
    t1, t2 = tangent_frames(normals)
    out = np.ones(len(points), dtype=bool)
    for off in (t1, -t1, t2, -t2):
        start = points + off * radius
        way = cameras - start
        way /= np.linalg.norm(way, axis=1, keepdims=True)
        out &= ~rays.segments_blocked(start + way * skip, cameras)
    return out


def seen_from_around(rays, starts, cameras, radius: float) -> np.ndarray:
    """Per (start, camera): whether the segment from ``start`` stays clear to every point
    within ``radius`` of the camera across its line of sight, judged at the four corners of
    the square circumscribing that disc: a straight edge that blocks some point of the disc
    blocks a corner (a post thinner than the disc could slip between them).

    Parameters
    ----------
    rays : RayCaster
    starts : (n, 3) float
        Segment starts (a surface point lifted off its surface).
    cameras : (n, 3) float
    radius : float
        How far the camera may stand off its position, metres.

    Returns
    -------
    (n,) bool
    """
    starts, cameras = np.asarray(starts, dtype=float), np.asarray(cameras, dtype=float)
    out = np.ones(len(starts), dtype=bool)
    if radius <= 0 or len(starts) == 0:
        return out
    way = cameras - starts
    way /= np.linalg.norm(way, axis=1, keepdims=True)
    t1, t2 = tangent_frames(way)
    for a, b in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
        rows = np.flatnonzero(out)
        out[rows] = ~rays.segments_blocked(starts[rows], cameras[rows] + radius * (a * t1[rows] + b * t2[rows]))
    return out


def in_view(x, y, z, dist, towards, tan_h: float, tan_v: float, reach: float, max_incidence_deg: float,
            ball_m: float = 0.0) -> np.ndarray:
    """Frustum, range and incidence tests from a point's camera-frame coordinates ``x, y, z``,
    its range and ``towards`` = normal . (camera - point). With ``ball_m`` they must hold for
    every point within ``ball_m`` (the incidence with the angle such a move can add).

    Parameters
    ----------
    x, y, z : (m,) float
        Camera-frame coordinates, z forward.
    dist : (m,) float
        Ranges, metres.
    towards : (m,) float
        normal . (camera - point).
    tan_h, tan_v : float
        Tangents of the half fields of view.
    reach : float
        The largest range, metres.
    max_incidence_deg : float
        Degrees.
    ball_m : float
        Metres.

    Returns
    -------
    (m,) bool
        The tests' verdict.
    """
    if ball_m <= 0:  # the ball's tests with e = 0, without an arcsin per pair (every visibility matrix)
        facing = towards >= np.cos(np.radians(max_incidence_deg)) * dist
        return ((z > 0) & (np.abs(x) <= tan_h * z) & (np.abs(y) <= tan_v * z) & (dist <= reach)
                & (dist > 0) & facing)
    e = ball_m
    with np.errstate(invalid="ignore", divide="ignore"):
        turn = np.arcsin(np.clip(e / dist, 0.0, 1.0))
    facing = towards >= np.cos(np.clip(np.radians(max_incidence_deg) - turn, 0.0, None)) * dist
    return ((z > e) & (np.abs(x) + e <= tan_h * (z - e)) & (np.abs(y) + e <= tan_v * (z - e))
            & (dist + e <= reach) & facing)


def _spatial_order(points, cell: float) -> np.ndarray:
    """Indices of points sorted cell by cell, so consecutive chunks are spatially compact."""
    key = np.floor((points - points.min(axis=0)) / max(cell, 1e-9)).astype(np.int64)
    return np.lexsort((key[:, 2], key[:, 1], key[:, 0]))


def visibility_matrix(n_cameras: int, n_points: int, pairs) -> tuple[sp.csr_matrix, np.ndarray]:
    """Boolean sparse matrix (cameras x points) from ``imaging_pairs`` output (no pair listed
    twice), with sorted indices, and the order of the pairs that gives its entries.

    Parameters
    ----------
    n_cameras, n_points : int
        The matrix's shape.
    pairs : tuple of (m,) arrays
        ``imaging_pairs``' camera and point indices (and ranges).

    Returns
    -------
    vis : scipy.sparse.csr_matrix
        Cameras by points.
    order : (m,) int
        The pairs in ``vis.data``'s order.
    """
    i, j, _ = pairs
    # One key per pair sorts 4x faster than lexsort; sorted, the pairs are the CSR entries.
    order = np.argsort(np.asarray(i, dtype=np.int64) * n_points + j)
    indptr = np.concatenate([[0], np.cumsum(np.bincount(i, minlength=n_cameras))])
    vis = sp.csr_matrix((np.ones(len(i), dtype=bool), np.asarray(j)[order], indptr), shape=(n_cameras, n_points))
    vis.has_sorted_indices = True
    return vis, order


def view_rays(cam_index, point_index, positions, points) -> np.ndarray:
    """Unit vectors from each point to the camera imaging it.

    Parameters
    ----------
    cam_index, point_index : (m,) int
        Camera and point of each pair.
    positions : (c, 3) float
        Camera centres.
    points : (n, 3) float
        Points.

    Returns
    -------
    (m, 3) float
        Unit vectors.
    """
    v = np.asarray(positions)[cam_index] - np.asarray(points)[point_index]
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _pair_cosines(point_index, rays, n_points: int, max_block: int = 4_000_000):
    """Yield (points, k x k cosines between their view rays) in blocks of points with >= 2 views.

    Points are padded with their first ray (a repeated ray adds only a 0 deg pair)."""
    point_index = np.asarray(point_index, dtype=np.int64)
    rays = np.asarray(rays, dtype=float).reshape(-1, 3)
    if len(point_index) == 0:
        return
    order = np.argsort(point_index, kind="stable")
    sorted_rays = rays[order]
    counts = np.bincount(point_index, minlength=n_points)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    many = np.flatnonzero(counts >= 2)
    # Pad points with similar view counts together so the k x k blocks stay small.
    size_class = np.ceil(np.log2(counts[many])).astype(int)
    for c in np.unique(size_class):
        members = many[size_class == c]
        k = int(counts[members].max())
        step = max(1, max_block // (k * k))
        slot = np.arange(k)
        for lo in range(0, len(members), step):
            block = members[lo:lo + step]
            idx = starts[block][:, None] + np.where(slot[None, :] < counts[block][:, None], slot[None, :], 0)
            vec = sorted_rays[idx]
            yield block, np.matmul(vec, vec.transpose(0, 2, 1))


def widest_pair_angle(point_index, rays, n_points: int, max_block: int = 4_000_000) -> np.ndarray:
    """Per point, the largest angle (deg) between two of its view rays; 0 with < 2 views.

    Parameters
    ----------
    point_index : (m,) int
        The point of each view.
    rays : (m, 3) float
        Unit rays.
    n_points : int
        Points.
    max_block : int
        Cosines per batch.

    Returns
    -------
    (n_points,) float
        Degrees.
    """
    widest = np.zeros(n_points)
    for block, cos in _pair_cosines(point_index, rays, n_points, max_block):
        widest[block] = np.degrees(np.arccos(np.clip(cos.min(axis=(1, 2)), -1.0, 1.0)))
    return widest


def pair_stats(point_index, rays, n_points: int, lo_deg: float, hi_deg: float | None) -> tuple[np.ndarray, np.ndarray]:
    """``widest_pair_angle`` and ``has_pair_between`` in one pass over the pair cosines.

    Parameters
    ----------
    point_index : (m,) int
        The point of each view.
    rays : (m, 3) float
        Unit rays.
    n_points : int
        Points.
    lo_deg : float
        The least angle.
    hi_deg : float or None
        The largest angle.

    Returns
    -------
    widest : (n_points,) float
        Degrees.
    ok : (n_points,) bool
        Has a pair in the window.
    """
    if hi_deg is None:
        widest = widest_pair_angle(point_index, rays, n_points)
        return widest, widest >= lo_deg
    widest = np.zeros(n_points)
    ok = np.zeros(n_points, dtype=bool)
    c_lo, c_hi = np.cos(np.radians(lo_deg)), np.cos(np.radians(hi_deg))
    for block, cos in _pair_cosines(point_index, rays, n_points):
        widest[block] = np.degrees(np.arccos(np.clip(cos.min(axis=(1, 2)), -1.0, 1.0)))
        ok[block] = ((cos <= c_lo + 1e-12) & (cos >= c_hi - 1e-12)).any(axis=(1, 2))
    return widest, ok


_FIRST_RAYS = 8  # has_pair_between's first look: 64 cosines a point instead of k x k


def has_pair_between(point_index, rays, n_points: int, lo_deg: float, hi_deg: float | None) -> np.ndarray:
    """Per point, whether two of its view rays meet at an angle in [lo_deg, hi_deg].

    ``hi_deg`` None means no upper bound (the thesis's rule: some pair at least lo_deg apart).
    A pair inside the window both triangulates (wide enough) and matches (narrow enough).
    Points are judged on their first few rays first: a pair found there is a pair of all, and
    only the points without one pay for the k x k cosines of all their rays.

    Parameters
    ----------
    point_index : (m,) int
        The point of each view.
    rays : (m, 3) float
        Unit rays.
    n_points : int
        Points.
    lo_deg : float
        The least angle.
    hi_deg : float or None
        The largest angle.

    Returns
    -------
    (n_points,) bool
        Points with a pair in the window.
    """
    point_index = np.asarray(point_index, dtype=np.int64)
    rays = np.asarray(rays, dtype=float).reshape(-1, 3)
    counts = np.bincount(point_index, minlength=n_points)
    if counts.max(initial=0) <= _FIRST_RAYS:
        return _has_pair_between(point_index, rays, n_points, lo_deg, hi_deg)
    order = np.argsort(point_index, kind="stable")
    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = run_offsets(counts)
    few = rank < _FIRST_RAYS
    ok = _has_pair_between(point_index[few], rays[few], n_points, lo_deg, hi_deg)
    rest = ~ok & (counts > _FIRST_RAYS)
    if rest.any():
        again = rest[point_index]
        ok[rest] = _has_pair_between(point_index[again], rays[again], n_points, lo_deg, hi_deg)[rest]
    return ok


def _has_pair_between(point_index, rays, n_points: int, lo_deg: float, hi_deg: float | None) -> np.ndarray:
    if hi_deg is None:
        return widest_pair_angle(point_index, rays, n_points) >= lo_deg
    ok = np.zeros(n_points, dtype=bool)
    c_lo, c_hi = np.cos(np.radians(lo_deg)), np.cos(np.radians(hi_deg))
    for block, cos in _pair_cosines(point_index, rays, n_points):
        ok[block] = ((cos <= c_lo + 1e-12) & (cos >= c_hi - 1e-12)).any(axis=(1, 2))
    return ok
