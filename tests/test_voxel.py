"""The voxel baseline reproduces the thesis's behaviour, failures included."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from shapely.geometry import box as rect

from coverplan import evaluate, load_scene, plan
from coverplan.shots.check_samples import planner_check_samples
from coverplan.voxel import (
    OBSTACLE,
    TARGET,
    grid_from_polygons,
    grid_from_scene,
    plan_2d,
    plan_3d,
    thesis_camera,
    view_plan,
)
from coverplan.voxel.view import shot_region, surface_cells
from coverplan.world.scene import scene_from_meshes
from tests.helpers import MESHES, box, gsd_for, load_script

shapes_2d = load_script(MESHES / "make_meshes.py").shapes_2d


@pytest.mark.parametrize("name", ["square", "l", "h", "triangle"])
def test_every_surface_point_seen_twice_without_obstacles(name):
    grid = grid_from_polygons([shapes_2d()[name]])
    vp = view_plan(grid.cells, 7.0, 3.0, 80.0, (0.5, 49.5))
    assert vp.failure is None
    assert vp.seen.min() >= 2
    assert len(vp.surface) == len(surface_cells(grid.cells))
    # viewpoints lie in the shot region: free, within d_opt of the target, security from all
    assert shot_region(grid.cells, 7.0, 3.0)[tuple(vp.cells.T)].all()


def test_thesis_shot_counts_are_reproduced(thesis_camera):
    """Table 4.2 gives 17 / 21 / 26 / 18 shots; the reproduction lands within a few."""
    gsd = gsd_for(thesis_camera, 7.0)
    thesis = {"square": 17, "l": 21, "h": 26, "triangle": 18}
    for name, shape in shapes_2d().items():
        plan_ = plan_2d(grid_from_polygons([shape]), thesis_camera, gsd, 3.0, (0.5, 49.5))
        assert plan_.route is not None and abs(plan_.route.shot.sum() - thesis[name]) <= 4, name


def test_fully_hidden_surface_is_not_coverable(thesis_camera):
    """Figure 4.5: obstacles closing off part of the target leave the thesis without a path."""
    square = shapes_2d()["square"]  # 17.5..32.5
    wall = rect(16.5, 15.0, 33.5, 16.5)  # along the whole south side, 1 m away: no room to look
    plan_ = plan_2d(grid_from_polygons([square], [wall]), thesis_camera, gsd_for(thesis_camera, 7.0), 3.0, (0.5, 49.5))
    assert plan_.route is None
    assert "cannot be seen from the shot region" in plan_.failures[0]
    # the mesh planner plans the rest and says what is hidden
    scene = scene_from_meshes([trimesh.creation.extrude_polygon(square, 1.0)],
                              [trimesh.creation.extrude_polygon(wall, 3.0)], ground=0.0)
    route = plan(scene, thesis_camera, gsd=gsd_for(thesis_camera, 7.0), security=3.0, min_altitude=0.0,
                 surface_classes=("facade",), spacing=0.5, start=[0.5, 49.5, 0.5])
    ev = evaluate(route, scene)
    # Over the 3 m wall, views 45-70 deg up still reach much of the 1 m high south face (12.1 of
    # its 15.5 m² imaged since the check rejects views that graze the wall's top: the repair
    # then probes for steeper ones); what stays hidden is there.
    hidden = ~ev.reachable
    assert ev.safe and ev.metrics["unreachable_area_m2"] > 2.5
    assert (ev.samples.normals[hidden, 1] < -0.9).all()
    listed = {tuple(np.round(u["position"], 6)) for u in route.uncovered}
    mine = evaluate(route, scene, samples=planner_check_samples(scene, route))  # what route.uncovered lists
    is_listed = np.array([tuple(np.round(p, 6)) in listed for p in mine.samples.points])
    assert (mine.covered | is_listed).all() and is_listed[~mine.reachable].all()
    assert ev.metrics["coverage_pct"] > 90  # the rest: grazing views over the wall, listed with why


def test_small_obstacle_between_slices_is_not_seen():
    """Figure 4.11: the slices at 5, 15 and 25 m miss an obstacle floating at 9-11 m ("for them
    it is not treated"): the baseline flies exactly the same façade shots with or without it.
    The mesh planner treats it and covers the wall behind it."""
    camera = thesis_camera()
    gsd = gsd_for(camera, 7.0)
    target = load_scene(MESHES / "thesis_prism.obj").targets[0].mesh
    small = box(23.5, 12.5, 9, 26.5, 14.5, 11)
    large = box(39.5, 22, 0, 43.5, 28, 32)
    scene = scene_from_meshes([target], [large, small])
    vox = plan_3d(scene, camera, gsd, 3.0, [0.5, 49.5, 0.5])
    grid = vox.grid
    lo, hi = grid.index_of(np.array([[23.6, 12.6, 9.1], [26.4, 14.4, 10.9]]))
    assert (grid.cells[lo[0]:hi[0] + 1, lo[1]:hi[1] + 1, lo[2]:hi[2] + 1] == OBSTACLE).any()  # the grid has it
    for z in (5.0, 15.0, 25.0):  # ... the slices do not
        assert not (grid.slice_at(z).cells[lo[0]:hi[0] + 1, lo[1]:hi[1] + 1] == OBSTACLE).any()
    without = plan_3d(scene_from_meshes([target], [large]), camera, gsd, 3.0, [0.5, 49.5, 0.5])
    facades = [np.array(f.positions)[np.array(f.shot)] for p in (vox, without) for f in p.flights if f.name == "facades"]
    np.testing.assert_allclose(facades[0], facades[1])
    mesh = evaluate(plan(scene, camera, gsd=gsd, security=3.0, start=[0.5, 49.5, 3.0]), scene)
    assert mesh.safe and mesh.metrics["coverage_pct"] >= 99.9
    pts = mesh.samples.points
    behind = (np.abs(pts[:, 1] - 18.5) < 1e-6) & (pts[:, 0] > 23.5) & (pts[:, 0] < 26.5) & (pts[:, 2] > 9) & (pts[:, 2] < 11)
    assert behind.sum() > 3 and mesh.covered[behind].all()


def test_rasterisers():
    grid = grid_from_polygons([shapes_2d()["l"]])
    assert (grid.cells == TARGET).sum() == pytest.approx(shapes_2d()["l"].area, rel=0.02)
    scene = load_scene(MESHES / "ring_prism.obj")
    grid3 = grid_from_scene(scene, 1.0, margin=5.0)
    assert (grid3.cells == TARGET).sum() == pytest.approx(scene.targets[0].mesh.volume, rel=0.02)


def test_ring_has_terrace_and_opposed_terrace_paths():
    camera = thesis_camera()
    vox = plan_3d(load_scene(MESHES / "ring_prism.obj"), camera, gsd_for(camera, 7.0), 3.0, [0.5, 49.5, 0.5])
    names = [f.name for f in vox.flights]
    assert names == ["terrace at 16.0 m", "rooftop at 30.0 m", "opposed terrace at 14.0 m", "facades"]
    pitches = {f.name: set(np.round(np.array(f.pitch)[np.array(f.shot)], 1)) for f in vox.flights}
    assert pitches["terrace at 16.0 m"] == {-45.0} and pitches["opposed terrace at 14.0 m"] == {45.0}
    assert pitches["facades"] == {0.0}
    assert vox.route.extra["flights"] == names
