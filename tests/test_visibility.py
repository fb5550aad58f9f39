"""imaging_pairs with a ball: a view it grants a sample holds for the surface around it."""

from __future__ import annotations

import numpy as np
import trimesh

from coverplan import get_camera
from coverplan.shots.visibility import imaging_pairs, seen_from_around
from coverplan.world.scene import scene_from_meshes
from tests.helpers import box
from tests.independent import images, segment_hits_triangles

MAX_RANGE_M, MAX_INCIDENCE_DEG = 12.0, 60.0


def test_ball_views_hold_around_each_sample():
    """Every (camera, sample) pair granted with a 0.2 m ball holds, by the independent rule,
    at points of the wall up to 0.2 m from the sample; the plain rule grants more pairs, some
    of which fail there."""
    rng = np.random.default_rng(7)
    e = 0.2
    scene = scene_from_meshes([box(-20, 0, 0, 20, 1, 20)])  # its face y = 0 looks towards -y
    camera = get_camera("phantom4pro")
    n = 400
    points = np.column_stack([rng.uniform(-8, 8, n), np.zeros(n), rng.uniform(2, 18, n)])
    normals = np.tile([0.0, -1.0, 0.0], (n, 1))
    cams = np.column_stack([rng.uniform(-6, 6, 60), rng.uniform(-12, -4, 60), rng.uniform(4, 16, 60)])
    heading = rng.uniform(-40, 40, 60)
    pitch = rng.uniform(-30, 20, 60)

    def pairs(ball_m):
        ci, pi, _r = imaging_pairs(cams, heading, pitch, camera, points, normals, scene.rays,
                                   max_range=MAX_RANGE_M, max_incidence_deg=MAX_INCIDENCE_DEG, ball_m=ball_m)
        return ci, pi

    with_ball, plain = pairs(e), pairs(0.0)
    assert 0 < len(with_ball[0]) < len(plain[0])
    tris = scene.parts[0].mesh.triangles
    angle = rng.uniform(0, 2 * np.pi, (16,))
    moves = e * np.column_stack([np.cos(angle), np.zeros(16), np.sin(angle)])
    moves[:4] *= 0.999  # the ball's rim and just inside it
    failures_plain = 0
    for (ci, pi), must_hold in ((with_ball, True), (plain, False)):
        for k in np.unique(ci):
            idx = pi[ci == k]
            around = (points[idx][:, None, :] + moves[None]).reshape(-1, 3)
            seen = images(cams[k], heading[k], pitch[k], camera, around, np.tile(normals[0], (len(around), 1)),
                          tris, MAX_RANGE_M, MAX_INCIDENCE_DEG).reshape(len(idx), len(moves))
            if must_hold:
                assert seen.all(), (k, idx[~seen.all(axis=1)])
            else:
                failures_plain += int((~seen.all(axis=1)).sum())
    assert failures_plain > 0  # the ball matters: some plain views end within 0.2 m


def test_sight_holds_wherever_the_photo_is_taken_in_passing():
    """A sample just beside a wall's end, cameras behind it: a sight line granted with the
    0.1 m a photo taken in passing may stand off its point stays clear, by the independent
    segment test, from every 10 deg of the 0.1 m rim across the line of sight round the camera;
    the lines clear only at the camera itself are refused, and some are."""
    rng = np.random.default_rng(3)
    r = 0.1
    # A wall ending at x = 4, turned 35 deg about y so its end slants across every frame.
    turn = trimesh.transformations.rotation_matrix(np.radians(35), [0, 1, 0])
    wall = box(0, 0, 0, 4, 0.3, 6).apply_transform(turn)
    scene = scene_from_meshes([wall])
    n = 4000
    starts = np.column_stack([rng.uniform(4.02, 4.3, n), rng.uniform(-2.0, -0.5, n), rng.uniform(1, 5, n)])
    cams = np.column_stack([rng.uniform(-6, 3.5, n), rng.uniform(2, 9, n), rng.uniform(0, 8, n)])
    starts, cams = (trimesh.transform_points(p, turn) for p in (starts, cams))
    tris = scene.parts[0].mesh.triangles
    at_camera = ~segment_hits_triangles(starts, cams, tris)
    ok = seen_from_around(scene.rays, starts, cams, r)
    assert not (ok & ~at_camera).any()
    assert (at_camera & ~ok).sum() > 10 and ok.sum() > 10
    way = cams - starts
    side = np.cross(way, rng.normal(size=(n, 3)))
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    other = np.cross(way / np.linalg.norm(way, axis=1, keepdims=True), side)
    for angle in np.radians(np.arange(0, 360, 10)):  # the rim across the sight line: the worst place
        move = r * (np.cos(angle) * side + np.sin(angle) * other)
        assert not segment_hits_triangles(starts[ok], cams[ok] + move[ok], tris).any()
    assert seen_from_around(scene.rays, starts, cams, 0.0).all()  # stopping: judged as planned elsewhere
