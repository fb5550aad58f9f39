"""Framed views (shots/framing.py): how much of a photo a sample's face fills, and the close
views the planner adds for narrow faces, judged with this file's own ray casts."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from coverplan import get_camera, load_scene, plan
from coverplan.shots.framing import (
    BEST_SHARE,
    FACING_DEG,
    FRAMED_INCIDENCE_DEG,
    MIN_FILL,
    frame_fill,
    framed_view_matrix,
    view_fill,
)
from coverplan.shots.reconstructability import MatchRule
from coverplan.shots.sharpness import add_wanted_views
from tests.helpers import box
from tests.independent import frame_share, polyline_min_distance

CAMERA = get_camera("phantom4pro")


def _scene(tmp_path, *meshes):
    path = tmp_path / "scene.obj"
    trimesh.util.concatenate(list(meshes)).export(path)
    return load_scene(path)


@pytest.mark.parametrize("heading, pitch, position", [
    (0.0, 0.0, (15.0, 2.0, 10.0)),  # square on to the wall's south face, 8 m off: the wall fills the frame
    (0.0, 0.0, (15.0, -30.0, 10.0)),  # 40 m off: it fills part of it
    (30.0, -20.0, (5.0, -6.0, 14.0)),  # oblique, the roof's edge and the sky in the frame
    (180.0, 0.0, (15.0, 2.0, 10.0)),  # looking away: nothing
])
def test_fill_is_the_share_of_the_frame_on_the_face(tmp_path, heading, pitch, position):
    wall = box(0, 10, 0, 30, 14, 20)  # south face at y = 10, facing -y
    scene = _scene(tmp_path, wall)
    fill = frame_fill(scene, np.array([position]), np.array([heading]), np.array([pitch]), CAMERA)
    got = view_fill(fill, np.array([0]), np.array([0]), np.array([[0.0, -1.0, 0.0]]))[0]
    want = frame_share(np.array(position), heading, pitch, CAMERA, scene.targets[0].mesh, [0.0, -1.0, 0.0],
                       FACING_DEG)
    # The planner's grid is coarser (24 x 16) and sorts normals into ~25 deg bins.
    assert abs(got - want) <= 0.06, (got, want)


def test_a_narrow_tower_fills_less_of_the_frame_than_a_wide_wall(tmp_path):
    """The same standoff, the same face direction: a 4.5 m tower face fills a fifth of the
    frame, a 30 m wall nearly all its width."""
    scene = _scene(tmp_path, box(0, 0, 0, 4.5, 4.5, 24), box(40, 0, 0, 70, 4.5, 24))
    pos = np.array([[2.25, -14.0, 12.0], [55.0, -14.0, 12.0]])
    fill = frame_fill(scene, pos, np.zeros(2), np.zeros(2), CAMERA)
    tower, wall = view_fill(fill, np.array([0, 1]), np.array([0, 0]), np.array([[0.0, -1.0, 0.0]]))
    mesh = scene.targets[0].mesh
    assert tower == pytest.approx(frame_share(pos[0], 0, 0, CAMERA, mesh, [0, -1, 0], FACING_DEG), abs=0.05)
    assert tower < 0.3 < MIN_FILL + 0.1 < wall


def test_framed_views_ask_the_fill_or_most_of_the_best_there_is():
    cam = np.array([0, 1, 2, 0, 1, 2, 3])
    pt = np.array([0, 0, 0, 1, 1, 1, 1])
    fill = np.array([0.40, 0.20, 0.30, 0.10, 0.12, 0.15, 0.5])
    inc = np.array([10.0, 10.0, 10.0, 10.0, 10.0, 10.0, FRAMED_INCIDENCE_DEG + 5])
    m = framed_view_matrix(cam, pt, fill, inc, 4, 2).toarray()
    # sample 0: MIN_FILL (0.25) is reachable; sample 1's best square view fills 0.15, so 0.12 counts
    assert m[:, 0].tolist() == [1, 0, 1, 0]
    assert m[:, 1].tolist() == [0, 1, 1, 0]  # camera 3 fills more but sees it too slanted
    assert sorted(add_wanted_views(m, np.array([1.0, 1.0]), np.array([0]), views=2).tolist()) == [0, 1, 2]


@pytest.fixture(scope="module")
def tower_plans(tmp_path_factory):
    """A 4.5 m square tower of 24 m beside a 10 m hall, planned with two framed views per sample
    and by default (none asked), both without edge views: the rule's own effect (edge views
    alone frame 98.1 % of the tower's faces twice, the rule 99.8 %)."""
    tmp = tmp_path_factory.mktemp("tower")
    scene = _scene(tmp, box(0, 0, 0, 4.5, 4.5, 24), box(4.5, -2, 0, 22.5, 6.5, 10))
    kw = dict(gsd=0.004, security=3.0, fly="stop", edge_views=False)
    return scene, plan(scene, CAMERA, match=MatchRule(framed_views=2), **kw), plan(scene, CAMERA, **kw)


def _fills(route, scene, points, normals) -> np.ndarray:
    """(shots, points): how much of each shot's frame the point's face fills, where the shot
    sees the point within FRAMED_INCIDENCE_DEG (unoccluded, in frame, within d_opt), else 0;
    by this file's own casts."""
    from tests.independent import images
    mesh = trimesh.util.concatenate([p.mesh for p in scene.targets])
    d_opt = route.camera.optimal_distance(route.params["gsd_m"])
    fills = np.zeros((len(route.shots), len(points)))
    for row, k in enumerate(route.shots):
        p, h, t = route.positions[k], route.heading_deg[k], route.pitch_deg[k]
        seen = images(p, h, t, route.camera, points, normals, mesh.triangles, d_opt, FRAMED_INCIDENCE_DEG)
        for face in np.unique(np.round(normals[seen], 3), axis=0):
            on = seen & np.all(np.isclose(np.round(normals, 3), face), axis=1)
            fills[row, on] = frame_share(p, h, t, route.camera, mesh, face, FACING_DEG)
    return fills


def test_narrow_tower_faces_get_framed_views_from_closer_in(tower_plans):
    scene, framed, plain = tower_plans
    mesh = scene.targets[0].mesh
    points, face = trimesh.sample.sample_surface_even(mesh, 3000, seed=5)
    normals = mesh.face_normals[face]
    high = (np.abs(normals[:, 2]) < 0.1) & (points[:, 2] > 12) & (points[:, 0] <= 4.5 + 1e-6)
    points, normals = points[high], normals[high]
    fills = [_fills(route, scene, points, normals) for route in (framed, plain)]
    # MIN_FILL, or where neither plan fills that much, BEST_SHARE of the best either gives (the
    # planner takes the best of all its candidates); 0.03 for the planner's coarser grid
    target = np.minimum(MIN_FILL, BEST_SHARE * np.maximum(fills[0].max(axis=0), fills[1].max(axis=0))) - 0.03
    with_rule, without = (((f >= target) & (f > 0)).sum(axis=0) for f in fills)
    assert framed.metrics["framed_view_shots"] > 0 and framed.params["framed_views"] == 2
    assert (with_rule >= 2).mean() >= 0.9, np.bincount(with_rule)
    assert (without >= 2).mean() < (with_rule >= 2).mean() - 0.1, np.bincount(without)
    # the views closer in, and the path flown to them, are still clear of the building by the
    # security distance
    d_opt = framed.camera.optimal_distance(framed.params["gsd_m"])
    dist = np.linalg.norm(framed.positions[framed.shots][:, None, :2] - points[None, :, :2], axis=2).min(axis=1)
    assert (dist < 0.8 * d_opt).any()
    assert polyline_min_distance(framed.positions, [p.mesh for p in scene.targets], 0.5) >= 3.0


def test_the_evaluator_reports_the_framed_views(tower_plans):
    from coverplan import evaluate
    scene, framed, plain = tower_plans
    got = evaluate(framed, scene).metrics
    was = evaluate(plain, scene).metrics
    assert got["framed_views_judged"] == 2 and was["framed_views_judged"] == 2  # "none asked" is judged by 2
    assert got["framed_view_pct"] >= 99.0
    assert was["framed_view_pct"] < got["framed_view_pct"] - 2.0, (was["framed_view_pct"], got["framed_view_pct"])
