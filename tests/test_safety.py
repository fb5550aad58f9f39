"""Clearance queries against trimesh's proximity (no FCL, no KD-tree bound)."""

import numpy as np
import pytest
import trimesh

from coverplan.geometry.clearance import ClearanceModel
from coverplan.geometry.raycast import RayCaster
from tests.helpers import box


def scene_meshes():
    return [box(0, 0, 0, 10, 10, 10), box(14, 0, 0, 14.3, 0.3, 12),
            trimesh.creation.icosphere(2, radius=2.0).apply_translation([5, 16, 6])]


def true_distance(meshes, pts, chunk=2000):
    d = np.full(len(pts), np.inf)
    for lo in range(0, len(pts), chunk):
        p = pts[lo:lo + chunk]
        for m in meshes:
            _, dist, _ = trimesh.proximity.closest_point(m, p)
            d[lo:lo + chunk] = np.minimum(d[lo:lo + chunk], np.where(m.contains(p), 0.0, dist))
    return d


@pytest.fixture(params=["fcl", "vectorised", "near"])
def settle_with(request, monkeypatch):
    """Unsure cases settled by one FCL query each, by triangle_distance's exact distances to
    every triangle, or to the triangles near each query (the scene's boxes are big triangles
    among the sphere's small ones: NearTriangles tests those against everything)."""
    from coverplan.geometry import clearance
    monkeypatch.setattr(clearance, "VECTORISED_UP_TO_TRIANGLES", 10 ** 6 if request.param == "vectorised" else 0)
    monkeypatch.setattr(clearance, "LOCAL_BELOW_TRIANGLES", 10 ** 6 if request.param == "near" else 0)
    return request.param


def test_point_queries_agree_with_trimesh(settle_with):
    meshes = scene_meshes()
    model = ClearanceModel(meshes, rays=RayCaster(meshes), cover_edge=1.0)
    pts = np.random.default_rng(0).uniform([-6, -6, 0], [22, 24, 16], size=(3000, 3))
    truth = true_distance(meshes, pts)
    outside = truth > 0  # the bound is about the surface; inside points are the ray test's job
    assert outside.sum() > 2000 and (~outside).sum() > 50
    assert (model.lower_bound(pts[outside]) <= truth[outside] + 1e-6).all()
    exact, _ = model.point_distance(pts[:300])
    outside = truth[:300] > 0
    np.testing.assert_allclose(exact[outside], truth[:300][outside], atol=1e-6)
    for radius in (0.5, 3.0):
        np.testing.assert_array_equal(model.points_clear(pts, radius), truth >= radius)


def test_segment_queries_see_thin_obstacles_between_endpoints(settle_with):
    meshes = scene_meshes()
    model = ClearanceModel(meshes, rays=RayCaster(meshes), cover_edge=1.0)
    rng = np.random.default_rng(1)
    a = rng.uniform([-6, -6, 1], [22, 24, 15], size=(150, 3))
    b = a + rng.normal(size=(150, 3)) * 6
    outside = (true_distance(meshes, a) > 0) & (true_distance(meshes, b) > 0)
    a, b = a[outside], b[outside]
    t = np.linspace(0, 1, 200)[None, :, None]
    dense = (a[:, None] * (1 - t) + b[:, None] * t).reshape(-1, 3)
    seg_truth = true_distance(meshes, dense).reshape(len(a), -1).min(axis=1)
    exact, _ = model.segment_distance(a, b)
    step = np.linalg.norm(b - a, axis=1) / 199
    assert (exact <= seg_truth + 1e-6).all() and (exact >= seg_truth - step).all()
    ok = model.segments_clear(a, b, 2.0)
    clear_margin = seg_truth >= 2.0 + step
    unclear = exact < 2.0 - 1e-9
    assert ok[clear_margin].all() and not ok[unclear].any()
    # the 0.3 m post between two far waypoints
    assert not model.segments_clear(np.array([[10, 0.15 + 1, 6.0]]), np.array([[20, 0.15 + 1, 6.0]]), 3.0)[0]


def test_polyline_clearance_is_exact_where_it_matters():
    meshes = scene_meshes()
    model = ClearanceModel(meshes, rays=RayCaster(meshes), cover_edge=1.0)
    rng = np.random.default_rng(4)
    pts = rng.uniform([-8, -8, 1], [24, 26, 15], size=(60, 3))
    pts = pts[true_distance(meshes, pts) > 0]
    dist, _which, exact = model.polyline_clearance(pts, 3.0)
    truth, _ = model.segment_distance(pts[:-1], pts[1:])
    assert dist.min() == pytest.approx(truth.min(), abs=1e-9)
    np.testing.assert_array_equal(dist < 3.0, truth < 3.0)
    assert (dist <= truth + 1e-9).all()
    np.testing.assert_allclose(dist[exact], truth[exact])


@pytest.mark.parametrize("exact", [True, False])
def test_halving_segment_check_for_big_meshes(monkeypatch, exact):
    """The path big meshes take (KD bounds on halved pieces) agrees with the truth."""
    from coverplan.geometry import clearance
    meshes = scene_meshes()
    monkeypatch.setattr(clearance, "LOCAL_BELOW_TRIANGLES", 0)
    model = ClearanceModel(meshes, rays=RayCaster(meshes), cover_edge=0.5)
    monkeypatch.setattr(clearance, "HALVING_FROM_TRIANGLES", 0)
    rng = np.random.default_rng(7)
    a = rng.uniform([-6, -6, 1], [22, 24, 15], size=(200, 3))
    b = a + rng.normal(size=(200, 3)) * 6
    outside = (true_distance(meshes, a) > 0) & (true_distance(meshes, b) > 0)
    a, b = a[outside], b[outside]
    truth, _ = model.segment_distance(a, b)
    ok = model.segments_clear(a, b, 2.0, exact=exact)
    assert not ok[truth < 2.0].any()  # never clear when it is not
    if exact:
        np.testing.assert_array_equal(ok, truth >= 2.0)
    else:
        assert ok[truth >= 2.0 + model.cover_radius * 2].all()
