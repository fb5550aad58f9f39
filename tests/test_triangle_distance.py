"""Exact point/segment-to-triangle distances: known answers, trimesh and dense sampling."""

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from coverplan.geometry.triangle_distance import (
    NearTriangles,
    point_triangle_distance,
    segment_segment_distance,
    segment_triangle_distance,
    segments_near_triangles,
)

TRI = np.array([[0.0, 0, 0], [4, 0, 0], [0, 3, 0]])


def one(fn, *rows):
    return float(fn(*(np.asarray(r, dtype=float)[None] for r in rows))[0])


@pytest.mark.parametrize(("point", "expected"), [
    ([1, 1, 2], 2.0),  # above the inside: the height
    ([-3, -4, 0], 5.0),  # beyond vertex a, in the plane
    ([2, -1, 1], np.sqrt(2)),  # beside edge ab
    ([4, 3, 0], 2.4),  # beyond the hypotenuse 3x + 4y = 12
])
def test_point_to_triangle_known(point, expected):
    assert one(point_triangle_distance, point, *TRI) == pytest.approx(expected)


def test_segments_known():
    # crossing the triangle: 0, whatever the endpoints' distances
    assert one(segment_triangle_distance, [1, 1, -5], [1, 1, 5], *TRI) == 0.0
    # parallel above the inside: its height; a vertical miss beside edge ab: the edge distance
    assert one(segment_triangle_distance, [0.5, 0.5, 1.5], [2, 0.5, 1.5], *TRI) == pytest.approx(1.5)
    assert one(segment_triangle_distance, [2, -2, -3], [2, -2, 3], *TRI) == pytest.approx(2.0)
    # skew lines: x axis and the line y = 1 along z, apart by 1
    assert one(segment_segment_distance, [-1, 0, 0], [1, 0, 0], [0, 1, -1], [0, 1, 1]) == pytest.approx(1.0)
    # parallel, overlapping and not; a segment of length 0 is a point
    assert one(segment_segment_distance, [0, 0, 0], [2, 0, 0], [1, 1, 0], [3, 1, 0]) == pytest.approx(1.0)
    assert one(segment_segment_distance, [0, 0, 0], [1, 0, 0], [3, 1, 0], [4, 1, 0]) == pytest.approx(np.sqrt(5))
    assert one(segment_segment_distance, [2, 2, 2], [2, 2, 2], [0, 0, 0], [4, 0, 0]) == pytest.approx(np.sqrt(8))
    # a degenerate (flat) triangle is its longest edge
    flat = np.array([[0.0, 0, 0], [2, 0, 0], [4, 0, 0]])
    assert one(point_triangle_distance, [2, 3, 0], *flat) == pytest.approx(3.0)
    assert one(segment_triangle_distance, [6, 1, 0], [6, -1, 0], *flat) == pytest.approx(2.0)


def test_points_agree_with_trimesh():
    rng = np.random.default_rng(3)
    tris = rng.normal(size=(400, 3, 3)) * rng.choice([0.2, 1.0, 4.0], size=(400, 1, 1))
    pts = rng.normal(size=(400, 3)) * 3
    mine = point_triangle_distance(pts, tris[:, 0], tris[:, 1], tris[:, 2])
    for k in range(0, 400, 40):  # trimesh per triangle (its closest point is per mesh)
        mesh = trimesh.Trimesh(tris[k], [[0, 1, 2]], process=False)
        _, d, _ = trimesh.proximity.closest_point(mesh, pts[k:k + 1])
        assert mine[k] == pytest.approx(d[0], abs=1e-9)


def sampled_distance(p, q, tri, n=120):
    """Least distance between dense samples of a segment and a triangle (an upper bound)."""
    t = np.linspace(0, 1, n)[:, None]
    seg = p * (1 - t) + q * t
    u, v = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    inside = u + v <= 1
    surf = tri[0] + u[inside][:, None] * (tri[1] - tri[0]) + v[inside][:, None] * (tri[2] - tri[0])
    from scipy.spatial import cKDTree
    return float(cKDTree(surf).query(seg)[0].min())


coord = st.floats(-5, 5, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(st.lists(coord, min_size=15, max_size=15))
def test_segment_distance_brackets_dense_samples(xs):
    v = np.array(xs).reshape(5, 3)
    p, q, tri = v[0], v[1], v[2:]
    mine = one(segment_triangle_distance, p, q, *tri)
    sampled = sampled_distance(p, q, tri)
    # samples can only be farther, by at most half a step along the segment and across the
    # triangle's sample grid
    step = np.linalg.norm(q - p) / 119 + np.ptp(tri, axis=0).max() / 119 * 2
    assert mine <= sampled + 1e-9
    assert mine >= sampled - step - 1e-9


def test_near_triangles_matches_the_distances():
    rng = np.random.default_rng(5)
    tris = rng.uniform(-10, 10, size=(60, 3, 3))
    a = rng.uniform(-12, 12, size=(500, 3))
    b = a + rng.normal(size=(500, 3)) * 3
    for radius in (0.5, 2.0):
        truth = np.zeros(len(a), dtype=bool)
        for k in range(len(tris)):
            t = np.repeat(tris[k][None], len(a), axis=0)
            truth |= segment_triangle_distance(a, b, t[:, 0], t[:, 1], t[:, 2]) < radius
        assert 50 < truth.sum() < 450
        np.testing.assert_array_equal(segments_near_triangles(a, b, tris, radius, max_pairs=7_000), truth)
        pt_truth = np.zeros(len(a), dtype=bool)
        for k in range(len(tris)):
            t = np.repeat(tris[k][None], len(a), axis=0)
            pt_truth |= point_triangle_distance(a, t[:, 0], t[:, 1], t[:, 2]) < radius
        np.testing.assert_array_equal(segments_near_triangles(a, a, tris, radius), pt_truth)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1), st.sampled_from([0.3, 1.0, 3.0]))
def test_near_triangles_index_agrees_with_every_triangle(seed, radius):
    """The KD-tree of triangle centres never drops a triangle that comes within the radius:
    a scan-like sheet of small triangles, a few long ones across it, segments of all lengths
    and points, against segments_near_triangles over every triangle."""
    rng = np.random.default_rng(seed)
    corner = rng.uniform(-10, 10, size=(400, 1, 3))
    small = corner + rng.normal(size=(400, 3, 3)) * 0.4
    big = rng.uniform(-12, 12, size=(5, 3, 3))
    index = NearTriangles(np.vstack([small, big]))
    assert 0 < len(index.big) <= 20 and len(index.small) >= 380
    a = rng.uniform(-12, 12, size=(300, 3))
    b = a + rng.normal(size=(300, 3)) * rng.choice([0.1, 2.0, 8.0], size=(300, 1))
    tris = np.vstack([small, big])
    np.testing.assert_array_equal(index(a, b, radius, chunk=64), segments_near_triangles(a, b, tris, radius))
    np.testing.assert_array_equal(index(a, a, radius), segments_near_triangles(a, a, tris, radius))
