import numpy as np
import pytest

from coverplan import load_scene
from coverplan.shots.surface import CLASS_NAMES, sample_surface
from coverplan.world.scene import scene_from_meshes
from tests.helpers import MESHES, box


def test_box_samples_cover_its_area_with_outward_normals():
    scene = scene_from_meshes([box(0, 0, 0, 10, 6, 4)])
    s = sample_surface(scene, 0.5)
    assert s.total_area == pytest.approx(2 * (60 + 40 + 24) - 60, rel=1e-9)  # bottom rests on the ground
    assert s.left_out["ground"] == pytest.approx(60)
    assert 0.5 * s.total_area / 0.25 < len(s) < 2.5 * s.total_area / 0.25
    outside = s.points + s.normals * 0.01
    assert not scene.parts[0].mesh.contains(outside).any()
    # samples are spread: nearest neighbours closer than the spacing, none stacked
    from scipy.spatial import cKDTree
    d, _ = cKDTree(s.points).query(s.points, k=2)
    assert np.median(d[:, 1]) < 0.5 and d[:, 1].min() > 1e-6


def test_ring_prism_classes_match_thesis_figure_3_1():
    scene = load_scene(MESHES / "ring_prism.obj")
    areas = sample_surface(scene, 0.5).class_areas()
    # core 13 x 13 x 30 with a ring 21 x 21 x 2 at 14-16 m
    assert areas["roof"] == pytest.approx(13 * 13, rel=0.05)
    assert areas["terrace"] == pytest.approx(21 * 21 - 13 * 13, rel=0.05)
    assert areas["opposed_terrace"] == pytest.approx(21 * 21 - 13 * 13, rel=0.05)
    assert areas["facade"] == pytest.approx(4 * 13 * 28 + 4 * 21 * 2, rel=0.05)
    assert set(areas) == set(CLASS_NAMES)


def test_gabled_roof_is_roof_not_terrace():
    areas = sample_surface(load_scene(MESHES / "gabled_house.obj"), 0.3).class_areas()
    assert areas["roof"] == pytest.approx(2 * 10 * 5, rel=0.05)
    assert areas["terrace"] == 0


def test_surface_in_contact_with_an_obstacle_is_left_out():
    scene = load_scene(MESHES / "flush_target.obj", [MESHES / "flush_obstacle.obj"])
    s = sample_surface(scene, 0.25)
    assert s.left_out["buried"] == pytest.approx(6 * 4, rel=0.1)  # the shed's 6 m x 4 m contact
    pts = s.points
    inside_contact = (np.abs(pts[:, 1] - 20) < 1e-6) & (np.abs(pts[:, 0] - 25) < 2.9) & (pts[:, 2] < 3.9)
    assert not inside_contact.any()
