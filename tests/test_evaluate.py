"""The evaluator against answers worked out by hand (issue 2's done-when cases)."""

from __future__ import annotations

import numpy as np
import pytest

from coverplan import Route, evaluate
from coverplan.shots.surface import SurfaceSamples
from coverplan.world.scene import scene_from_meshes
from tests.helpers import box, gsd_for
from tests.independent import images

D_OPT = 7.0
SECURITY = 3.0
WALL = (0, 0, 0, 10, 0.5, 10)  # a 10 m x 10 m wall, its south face on y = 0


def one_shot_route(camera, shots, extra=()):
    """start -> shots (heading 0 = north, facing the wall) -> start, all at the first shot."""
    start = np.asarray(shots[0][0], float) + [0, -3.0, 0]
    pos = [start] + [np.asarray(p, float) for p, _h, _p in shots] + [start]
    shot = [False] + [True] * len(shots) + [False]
    head = [0.0] + [h for _p, h, _ in shots] + [0.0]
    pitch = [0.0] + [p for _x, _h, p in shots] + [0.0]
    legs = ["initial"] + ["coverage"] * len(shots) + ["final"]
    return Route(pos, shot, head, pitch, legs, camera,
                 {"gsd_m": gsd_for(camera, D_OPT), "security_m": SECURITY, "min_altitude_m": 1.0, **dict(extra)})


def south_face(ev):
    return np.flatnonzero(ev.samples.normals[:, 1] < -0.99)


def expected_in_view(points, cam, camera):
    """Frustum + range of a camera at ``cam`` looking north at the wall, worked out by hand."""
    dx, dz = points[:, 0] - cam[0], points[:, 2] - cam[2]
    depth = -cam[1]
    return ((np.abs(dx) <= depth * camera.tan_half_hfov) & (np.abs(dz) <= depth * camera.tan_half_vfov)
            & (dx ** 2 + dz ** 2 + depth ** 2 <= D_OPT ** 2))


def shadow_of_box(points, cam, lo, hi):
    """Slab test: does the segment point -> cam cross the axis-aligned box [lo, hi]?"""
    d = cam - points
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (lo - points) / d, (hi - points) / d
    tmin = np.nanmax(np.minimum(t1, t2), axis=1)
    tmax = np.nanmin(np.maximum(t1, t2), axis=1)
    return (tmax >= np.maximum(tmin, 0)) & (tmin <= 1)


def test_one_shot_images_exactly_its_frustum_and_range(thesis_camera):
    scene = scene_from_meshes([box(*WALL)])
    cam = np.array([5.0, -5.0, 5.0])
    ev = evaluate(one_shot_route(thesis_camera, [(cam, 0.0, 0.0)]), scene, spacing=0.25)
    face = south_face(ev)
    expected = expected_in_view(ev.samples.points[face], cam, thesis_camera)
    assert 50 < expected.sum() < len(face)  # the frame sees part of the face, not all of it
    np.testing.assert_array_equal(ev.views[face] == 1, expected)
    others = np.setdiff1d(np.arange(len(ev.samples)), face)
    assert (ev.views[others] == 0).all()
    # the brute-force checker (no Embree) agrees sample by sample
    brute = images(cam, 0.0, 0.0, thesis_camera, ev.samples.points, ev.samples.normals,
                   scene.parts[0].mesh.triangles, D_OPT, 70.0)
    np.testing.assert_array_equal(ev.views == 1, brute)


def test_obstacle_removes_exactly_its_shadow(thesis_camera):
    lo, hi = np.array([4.0, -2.5, 4.0]), np.array([6.0, -2.0, 6.0])
    scene = scene_from_meshes([box(*WALL)], [box(*lo, *hi)])
    cam = np.array([5.0, -5.0, 5.0])
    ev = evaluate(one_shot_route(thesis_camera, [(cam, 0.0, 0.0)]), scene, spacing=0.25)
    face = south_face(ev)
    pts = ev.samples.points[face]
    in_view = expected_in_view(pts, cam, thesis_camera)
    shadow = shadow_of_box(pts + [0, -1e-3, 0], cam, lo, hi)
    assert (in_view & shadow).sum() > 20
    np.testing.assert_array_equal(ev.views[face] == 1, in_view & ~shadow)


def test_waypoint_inside_security_distance_is_unsafe(thesis_camera):
    scene = scene_from_meshes([box(*WALL)])
    near = np.array([5.0, -(SECURITY - 0.5), 5.0])
    ev = evaluate(one_shot_route(thesis_camera, [(near, 0.0, 0.0)]), scene, spacing=1.0)
    assert not ev.safe
    assert ev.metrics["min_clearance_m"] == pytest.approx(SECURITY - 0.5, abs=1e-6)
    assert ev.metrics["unsafe_segment_count"] >= 1


def test_segment_clipping_an_obstacle_corner_is_unsafe(thesis_camera):
    # Both waypoints are far from everything; the straight line between them passes 1 m from
    # the corner of a post standing in the open.
    post = box(20, 20, 0, 20.2, 20.2, 12)
    scene = scene_from_meshes([box(*WALL)], [post])
    a, b = np.array([12.0, 21.2, 6.0]), np.array([28.0, 21.2, 6.0])  # 1 m north of the post
    route = Route([a, b, a], [True, False, False], [0, 0, 0], [0, 0, 0], ["coverage", "final", "final"],
                  thesis_camera, {"gsd_m": gsd_for(thesis_camera, D_OPT), "security_m": SECURITY})
    ev = evaluate(route, scene, spacing=1.0)
    assert not ev.safe
    assert ev.metrics["min_clearance_m"] == pytest.approx(1.0, abs=1e-3)
    assert "obstacle" in ev.metrics["min_clearance_mesh"]
    assert {s["segment"] for s in ev.metrics["unsafe_segments"]} == {0, 1}


def single_sample(point, normal):
    return SurfaceSamples(np.array([point], float), np.array([normal], float), np.array([1.0]),
                          np.array([0]), np.array([0], np.int8), 1.0)


@pytest.mark.parametrize("separation_deg, outlier", [(3.0, True), (6.0, False)])
def test_views_3_degrees_apart_make_a_p_outlier(thesis_camera, separation_deg, outlier):
    scene = scene_from_meshes([box(*WALL)])
    target = np.array([5.0, 0.0, 5.0])
    c1 = np.array([5.0, -5.0, 5.0])
    c2 = target + 5.0 * np.array([np.sin(np.radians(separation_deg)), -np.cos(np.radians(separation_deg)), 0])
    ev = evaluate(one_shot_route(thesis_camera, [(c1, 0.0, 0.0), (c2, 0.0, 0.0)]), scene,
                  samples=single_sample(target, [0, -1, 0]))
    assert ev.views[0] == 2
    assert ev.widest_deg[0] == pytest.approx(separation_deg, abs=1e-6)
    assert ev.metrics["p_outliers"] == int(outlier)
    assert ev.covered[0] == (not outlier)


def test_wall_behind_a_flush_obstacle_is_unreachable(thesis_camera):
    shed = box(3, -2.3, 0, 7, -0.3, 6)  # 0.3 m in front of the wall: too tight to look through
    scene = scene_from_meshes([box(*WALL)], [shed])
    cam = np.array([5.0, -8.0, 8.0])
    ev = evaluate(one_shot_route(thesis_camera, [(cam, 0.0, 0.0)]), scene, spacing=0.5)
    pts = ev.samples.points
    # Behind the shed and at least 1 m from its edges: looking out through the 0.3 m gap needs an
    # incidence of atan(1 / 0.3) = 73 deg or more, over the 70 deg limit.
    behind = (ev.samples.normals[:, 1] < -0.99) & (pts[:, 0] > 4) & (pts[:, 0] < 6) & (pts[:, 2] < 5 - 1e-9)
    open_wall = (ev.samples.normals[:, 1] < -0.99) & (pts[:, 2] > 8.5)
    assert behind.sum() > 10
    assert not ev.reachable[behind].any()
    assert ev.reachable[open_wall].all()
    assert all("obstacle" in ev.reasons[k] for k in np.flatnonzero(behind))
    assert ev.metrics["unreachable_area_m2"] >= behind.sum() * 0.2
    # unreachable surface is reported, not counted as a miss
    assert ev.metrics["reachable_area_m2"] == pytest.approx(ev.samples.area[ev.reachable].sum())


def test_orientation_mismatch_and_altitude_are_reported(thesis_camera):
    scene = scene_from_meshes([box(*WALL)])
    route = one_shot_route(thesis_camera, [(np.array([5.0, -5.0, 0.5]), 0.0, 0.0)])
    route.view_dir[1] = [1.0, 0.0, 0.0]  # says east while heading says north
    ev = evaluate(route, scene, spacing=1.0)
    assert ev.metrics["orientation_mismatches"] == 1
    assert ev.metrics["altitude_violations"] >= 1  # z 0.5 < ground 0 + min altitude 1
    assert not ev.safe


def test_photos_at_the_two_ends_of_a_long_wall_are_two_sets_and_the_summary_says_so(thesis_camera):
    from coverplan.cli.summary import photo_sets_row

    scene = scene_from_meshes([box(0, 0, 0, 40, 0.5, 10)])
    # two photos a step apart at each end of a 40 m wall, 5 m off it: each pair shares most of
    # its view, the two ends share nothing
    shots = [((x, -5.0, 5.0), 0.0, 0.0) for x in (4.0, 6.0, 34.0, 36.0)]
    graph = evaluate(one_shot_route(thesis_camera, shots), scene, spacing=0.25).metrics["shot_graph"]
    assert graph["components"] == 2 and graph["largest_component"] == 2
    name, text = photo_sets_row(graph)
    assert name == "photo sets" and text.startswith("2 (largest 2 of 4 photos)") and "WARNING" in text
    # the same photos spread along the wall a step apart link into one set
    joined = [((x, -5.0, 5.0), 0.0, 0.0) for x in np.arange(4.0, 37.0, 2.0)]
    graph = evaluate(one_shot_route(thesis_camera, joined), scene, spacing=0.25).metrics["shot_graph"]
    assert graph["components"] == 1
    assert "WARNING" not in photo_sets_row(graph)[1]
