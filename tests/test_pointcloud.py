"""Point clouds as obstacles: a tree given as LiDAR points beside a house keeps the security
distance and blocks views; checked against the raw points, not the voxel mesh."""

from __future__ import annotations

import laspy
import numpy as np
import pytest
from scipy.spatial import cKDTree

from coverplan import evaluate, get_camera, load_scene, plan
from coverplan.errors import InputFileError, ParameterError
from coverplan.world.pointcloud import parse_classes, voxel_mesh
from tests.helpers import box
from tests.independent import polyline_min_distance

SECURITY = 2.0


def write_las(path, xyz, classes):
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales = np.array([0.001, 0.001, 0.001])
    header.offsets = xyz.min(axis=0)
    las = laspy.LasData(header)
    las.x, las.y, las.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    las.classification = classes
    las.write(path)
    return path


def tree_cloud(rng):
    """A trunk (r 0.3 m, 0-4 m) and a crown (sphere r 2.5 m at 6 m) at (5, -5), classes 5 and
    4; a ground sheet (class 2) over the site; three noise points (class 7) in the sky."""
    t = rng.uniform(0, 2 * np.pi, 4000)
    trunk = np.column_stack([5 + 0.3 * np.cos(t), -5 + 0.3 * np.sin(t), rng.uniform(0, 4, 4000)])
    d = rng.normal(size=(30000, 3))
    crown = [5, -5, 6] + 2.5 * d / np.linalg.norm(d, axis=1, keepdims=True) * rng.uniform(0.3, 1, (30000, 1)) ** 0.3
    ground = np.column_stack([rng.uniform(-20, 30, 20000), rng.uniform(-25, 30, 20000), np.full(20000, -0.2)])
    noise = np.array([[0.0, 0.0, 60.0], [3.0, 3.0, 70.0], [6.0, 1.0, 80.0]])
    xyz = np.vstack([trunk, crown, ground, noise])
    classes = np.concatenate([np.full(len(trunk), 5), np.full(len(crown), 4), np.full(len(ground), 2), [7, 7, 7]])
    return xyz, classes.astype(np.uint8)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tree")
    house = folder / "house.obj"
    box(0, 0, 0, 10, 8, 6).export(house)
    xyz, classes = tree_cloud(np.random.default_rng(7))
    cloud = write_las(folder / "tree.las", xyz, classes)
    return house, cloud, xyz, classes


def test_voxels_contain_every_point():
    rng = np.random.default_rng(1)
    pts = rng.uniform(-3, 3, (2000, 3)) * [1, 1, 0.2]
    keys = np.unique(np.floor(pts / 0.5).astype(int), axis=0)
    mesh = voxel_mesh(keys, 0.5)
    # Closed, outward and manifold; voxels touching only along an edge were joined, so it
    # holds at least the voxels' volume.
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.volume >= len(keys) * 0.5 ** 3 - 1e-9
    assert mesh.contains(pts).all()


def test_the_tree_is_an_obstacle_and_ground_and_noise_are_not(site):
    house, cloud, _xyz, _classes = site
    scene = load_scene(house, obstacle_points=[cloud])
    [tree] = [p for p in scene.obstacles if p.name == "points 'tree.las'"]
    lo, hi = tree.mesh.bounds + scene.origin  # back in the input's coordinates
    assert lo[2] >= 0.0 - 1e-9 and hi[2] <= 8.5 + 1e-9  # no ground sheet at -0.2, no noise at 60-80 m
    assert np.all(lo[:2] >= [2.0, -8.0]) and np.all(hi[:2] <= [8.0, -2.0])
    assert any("points kept as obstacles" in n for n in scene.notes)
    with_ground = load_scene(house, obstacle_points=[cloud], point_classes=parse_classes("2,4,5"))
    [both] = [p for p in with_ground.obstacles if p.name == "points 'tree.las'"]
    assert both.mesh.bounds[0][2] + with_ground.origin[2] < 0.0


def test_plans_keep_the_security_distance_from_every_point(site):
    house, cloud, xyz, classes = site
    camera = get_camera("phantom4pro")
    scene = load_scene(house, obstacle_points=[cloud])
    route = plan(scene, camera, gsd=0.003, security=SECURITY)
    src = route.positions + scene.origin
    step = 0.1
    dense = [src[:1]]
    for a, b in zip(src[:-1], src[1:]):
        n = max(int(np.ceil(np.linalg.norm(b - a) / step)), 1)
        t = np.linspace(0, 1, n + 1)[1:, None]
        dense.append(a * (1 - t) + b * t)
    kept = xyz[~np.isin(classes, (2, 7, 18))]
    nearest = cKDTree(kept).query(np.vstack(dense))[0]
    assert nearest.min() >= SECURITY  # sampled every 0.1 m along the flight
    house_only = load_scene(house)
    assert polyline_min_distance(route.positions + scene.origin - house_only.origin, [p.mesh for p in house_only.parts],
                                 step=0.25) >= SECURITY - 1e-6
    ev = evaluate(route, scene)
    assert ev.safe
    # The same house planned without the tree flies through it.
    blind = plan(house_only, camera, gsd=0.003, security=SECURITY)
    blind_src = blind.positions + house_only.origin
    assert cKDTree(kept).query(blind_src)[0].min() < SECURITY


def test_bad_clouds_are_refused(site, tmp_path):
    house, cloud, xyz, classes = site
    with pytest.raises(InputFileError, match="has no points of classes 14"):
        load_scene(house, obstacle_points=[cloud], point_classes=(14,))
    with pytest.raises(ParameterError, match="LAS class numbers"):
        parse_classes("trees")
    junk = tmp_path / "junk.laz"
    junk.write_bytes(b"not a point cloud" * 10)
    with pytest.raises(InputFileError, match="junk.laz: cannot be read as a LAS/LAZ point cloud"):
        load_scene(house, obstacle_points=[junk])


def test_wall_behind_a_hedge_is_reported_hidden_by_it(tmp_path):
    """A hedge of points 1.5 m before a wall, as tall as the wall: its middle hides the wall's
    foot from every safe viewpoint, and the reason names the hedge."""
    house = tmp_path / "house.obj"
    box(0, 0, 0, 10, 8, 6).export(house)
    rng = np.random.default_rng(5)
    xyz = np.column_stack([rng.uniform(1, 9, 60000), rng.uniform(-3.5, -1.5, 60000), rng.uniform(0, 6, 60000)])
    cloud = write_las(tmp_path / "hedge.las", xyz, np.full(len(xyz), 4, np.uint8))
    scene = load_scene(house, obstacle_points=[cloud])
    route = plan(scene, get_camera("phantom4pro"), gsd=0.003, security=2.0)
    ev = evaluate(route, scene)
    assert ev.safe
    hidden = [g for g in ev.metrics["unreachable"] if "occluded by obstacle points 'hedge.las'" in g["reason"]]
    assert hidden and sum(g["area_m2"] for g in hidden) > 0.3
    for g in hidden:  # on the south wall, behind the hedge, below its top
        (x0, y0, z0), (x1, y1, z1) = g["bounds"]
        assert abs(y0) < 0.05 and abs(y1) < 0.05 and 1.0 <= x0 <= x1 <= 9.0 and z1 <= 6.0
    # Without the hedge that wall is all covered.
    bare = evaluate(plan(load_scene(house), get_camera("phantom4pro"), gsd=0.003, security=2.0), load_scene(house))
    assert bare.metrics["unreachable_area_m2"] < 0.05
