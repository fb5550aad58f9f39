"""Mesh preparation, obstacle merging and the plan-size guard, on meshes with known faults."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from coverplan import PlanningError, evaluate, get_camera, load_scene, plan
from coverplan.shots.surface import sample_surface
from coverplan.world.merge import merge_into_target
from coverplan.world.prepare import orient_faces, prepare_mesh
from coverplan.world.scene import scene_from_meshes
from tests.helpers import MESHES, box, gsd_for


def messy_box(seed=0, flip_fraction=0.3, drop=0):
    mesh = box(0, 0, 0, 10, 8, 6).subdivide().subdivide()
    rng = np.random.default_rng(seed)
    faces = mesh.faces.copy()
    flip = rng.random(len(faces)) < flip_fraction
    faces[flip] = faces[flip][:, ::-1]
    faces = np.vstack([faces, faces[:7], [[0, 0, 1]]])  # 7 duplicates and a degenerate face
    if drop:
        faces = np.delete(faces, rng.choice(len(mesh.faces), drop, replace=False), axis=0)
    return trimesh.Trimesh(mesh.vertices, faces, process=False), mesh


def test_preparation_repairs_and_says_so():
    messy, clean = messy_box()
    fixed, notes = prepare_mesh(messy, "m")
    text = " ".join(notes)
    assert "dropped 7 duplicate faces" in text and "degenerate" in text and "re-oriented" in text
    assert fixed.is_watertight and fixed.volume == pytest.approx(clean.volume)
    np.testing.assert_allclose(np.sort(fixed.face_normals, axis=0), np.sort(clean.face_normals, axis=0), atol=1e-9)


def test_open_mesh_with_flipped_faces_gets_outward_sample_normals():
    messy, clean = messy_box(flip_fraction=0.4, drop=6)  # six holes: not a closed solid
    scene = scene_from_meshes([messy])
    assert not scene.targets[0].mesh.is_watertight
    s = sample_surface(scene, 0.5)
    outside = s.points + s.normals * 0.05
    assert not clean.contains(outside).any()  # every sample's normal points out of the true solid


def test_orientation_of_many_bodies_is_vectorised_and_right():
    parts = [trimesh.creation.icosphere(4).apply_translation([3 * k, 0, 0]) for k in range(5)]
    mesh = trimesh.util.concatenate(parts)
    rng = np.random.default_rng(2)
    flip = rng.random(len(mesh.faces)) < 0.5
    faces = np.where(flip[:, None], mesh.faces[:, ::-1], mesh.faces)
    scrambled = trimesh.Trimesh(mesh.vertices, faces, process=False)
    assert orient_faces(scrambled) == flip.sum()
    np.testing.assert_array_equal(scrambled.faces, mesh.faces)


def test_merge_obstacles_within(thesis_camera):
    scene = load_scene(MESHES / "flush_target.obj", [MESHES / "flush_obstacle.obj"])
    merged = merge_into_target(scene, 0.5)
    assert len(merged.targets) == 1 and not merged.obstacles
    assert any("united" in n for n in merged.notes)
    shed_front = sample_surface(merged, 0.5)
    front = (np.abs(shed_front.points[:, 1] - 17) < 1e-6) & (shed_front.normals[:, 1] < -0.99)
    assert front.sum() > 10  # the shed's outside is now surface to image
    route = plan(merged, thesis_camera, gsd=gsd_for(thesis_camera, 7.0), security=3.0)
    ev = evaluate(route, merged)
    assert ev.safe and ev.metrics["coverage_pct"] >= 99.9
    far = merge_into_target(scene, -1.0)  # nothing that close
    assert len(far.obstacles) == 1


def test_overlapping_target_parts_are_united(tmp_path):
    a, b = box(0, 0, 0, 10, 10, 8), box(6, 6, 0, 16, 16, 12)
    path = tmp_path / "parts.glb"
    s = trimesh.Scene()
    s.add_geometry(a, node_name="a", geom_name="a")
    s.add_geometry(b, node_name="b", geom_name="b")
    s.export(path)
    scene = load_scene(path, up_axis="z")
    assert len(scene.targets) == 1 and any("united 2 overlapping" in n for n in scene.notes)
    assert scene.targets[0].mesh.volume == pytest.approx(800 + 1200 - 4 * 4 * 8)


def test_plan_size_guard_refuses_before_work(thesis_camera):
    scene = load_scene(MESHES / "l_prism.obj")
    with pytest.raises(PlanningError, match="needs about"):
        plan(scene, thesis_camera, gsd=gsd_for(thesis_camera, 7.0), security=3.0, spacing=0.005, max_memory=1e9)


def test_georeferenced_mesh_far_from_origin_plans_safely():
    """10^6 m coordinates: shifted to a local origin first, so float32 cannot eat the distance."""
    far = box(500000, 5400000, 200, 500012, 5400010, 212)
    scene = scene_from_meshes([far], [box(500016, 5400000, 200, 500017, 5400001, 215)])
    camera = get_camera("phantom4pro")
    route = plan(scene, camera, gsd=0.004, security=3.0)
    ev = evaluate(route, scene)
    assert ev.safe and ev.metrics["min_clearance_m"] >= 3.0 and ev.metrics["coverage_pct"] == pytest.approx(100.0)
    assert route.frame["origin"][0] == pytest.approx(500006, abs=1)
