import numpy as np
import pytest
import trimesh

from coverplan import InputFileError, ParameterError, load_scene
from coverplan.world.scene import scene_from_meshes
from tests.helpers import MESHES, box


@pytest.mark.parametrize("ext", ["obj", "ply", "stl", "off", "glb"])
def test_every_mesh_format_loads_to_the_same_box(tmp_path, ext):
    mesh = box(0, 0, 0, 10, 6, 4)
    path = tmp_path / f"b.{ext}"
    if ext == "glb":
        # glTF is y-up: store the box rotated so that it comes back z-up
        y_up = mesh.copy()
        y_up.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))
        trimesh.Scene(y_up).export(path)
    else:
        mesh.export(path)
    scene = load_scene(path)
    np.testing.assert_allclose(scene.targets[0].mesh.bounds, [[0, 0, 0], [10, 6, 4]], atol=1e-6)
    assert scene.targets[0].mesh.area == pytest.approx(2 * (60 + 40 + 24))


def test_units_scale_to_metres(tmp_path):
    path = tmp_path / "mm.stl"
    box(0, 0, 0, 10000, 6000, 4000).export(path)
    scene = load_scene(path, units="mm")
    np.testing.assert_allclose(scene.targets[0].mesh.extents, [10, 6, 4], atol=1e-9)


def test_named_objects_pick_targets_and_the_rest_are_obstacles(tmp_path):
    s = trimesh.Scene()
    s.add_geometry(box(0, 0, 0, 10, 10, 10), node_name="hall", geom_name="hall")
    s.add_geometry(box(15, 0, 0, 16, 1, 8), node_name="tree", geom_name="tree")
    path = tmp_path / "site.glb"
    s.export(path)
    scene = load_scene(path, target_names=["hall"], up_axis="z")
    roles = {p.name: p.role for p in scene.parts}
    assert roles == {"site:hall": "target", "site:tree": "obstacle"}
    with pytest.raises(ParameterError, match="no object named"):
        load_scene(path, target_names=["church"], up_axis="z")


def test_far_away_coordinates_move_to_a_local_origin():
    far = box(500000, 5400000, 100, 500010, 5400010, 110)
    scene = scene_from_meshes([far])
    assert np.abs(scene.targets[0].mesh.bounds[:, :2]).max() < 100  # heights of 100 m stay
    np.testing.assert_allclose(scene.to_source(scene.targets[0].mesh.bounds), far.bounds)
    assert scene.ground_z == pytest.approx(100 - scene.origin[2])


def test_ground_defaults_to_the_lowest_target_point():
    scene = load_scene(MESHES / "thesis_prism.obj", [MESHES / "fig411_obstacles.obj"])
    assert scene.ground_z == 0.0
    assert [p.role for p in scene.parts] == ["target", "obstacle"]


def test_refuses_a_scene_without_faces(tmp_path):
    path = tmp_path / "flat.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")  # one degenerate face
    with pytest.raises(InputFileError, match="no usable faces"):
        load_scene(path)
