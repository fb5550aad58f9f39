"""The flight graph: a lattice built before the shots are known serves only the graph it is
the lattice of, and then gives exactly the graph built from scratch."""

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import trimesh
from scipy.sparse.csgraph import dijkstra

from coverplan import load_scene
from coverplan.flight.lattice import build_lattice, lattice_box
from coverplan.flight.pathing import build_flight_graph, shot_distances
from coverplan.shots.limits import scene_limits
from coverplan.world.scene import scene_from_meshes
from tests.helpers import MESHES, box

SECURITY, D_OPT, MARGIN, H = 3.0, 7.0, 0.06, 2.0


@pytest.fixture(scope="module")
def house():
    scene = load_scene(MESHES / "gabled_house.obj")
    limits = scene_limits(scene, security=SECURITY, d_opt=D_OPT, max_incidence_deg=70.0, min_altitude=SECURITY,
                          pitch_range_deg=(-90.0, 30.0), vfov_deg=50.0)
    return scene, limits


def _same_graph(a, b) -> bool:
    return (a.n_lattice == b.n_lattice and np.array_equal(a.points, b.points)
            and (a.graph != b.graph).nnz == 0)


def _shots(scene, n=12, seed=0):
    """Points a shot could be at: 4-6 m off the target's bounding box, above the ground."""
    lo, hi = scene.bounds("target")
    rng = np.random.default_rng(seed)
    side = rng.integers(0, 4, n)
    t = rng.random(n)
    x = np.where(side == 0, lo[0] - 5, np.where(side == 1, hi[0] + 5, lo[0] + t * (hi[0] - lo[0])))
    y = np.where(side == 2, lo[1] - 5, np.where(side == 3, hi[1] + 5, lo[1] + t * (hi[1] - lo[1])))
    y = np.where(side < 2, lo[1] + t * (hi[1] - lo[1]), y)
    return np.column_stack([x, y, SECURITY + 1 + rng.random(n) * (hi[2] - SECURITY)])


def _start(scene, off_x):
    lo = scene.bounds("target")[0]
    return np.array([lo[0] - off_x, lo[1] - 5.0, 3.5])


@pytest.mark.parametrize("off_x", [5.0, 120.0], ids=["near", "far"])
def test_lattice_built_beforehand_gives_the_same_graph(house, off_x):
    scene, limits = house
    start = _start(scene, off_x)
    specials = np.vstack([start, _shots(scene)])
    early = build_lattice(scene, limits, lattice_box(scene, limits, np.zeros((0, 3)), H), start,
                          margin=MARGIN, spacing=H)
    assert (early.coarse_step is not None) == (off_x > 100)
    fresh = build_flight_graph(scene, limits, specials, margin=MARGIN, spacing=H)
    reused = build_flight_graph(scene, limits, specials, margin=MARGIN, spacing=H, lattice=early)
    assert _same_graph(fresh, reused)
    assert fresh.graph.nnz > 10 * len(specials)


def test_shot_distances_shared_with_a_pool_are_the_searches_of_every_shot(house):
    """150 shots come in three blocks of sources, one searched on the pool: the costs are
    those of one scipy search from every special point, cut at the limit."""
    scene, limits = house
    specials = np.vstack([_start(scene, 5.0), _shots(scene, n=150, seed=4)])
    fg = build_flight_graph(scene, limits, specials, margin=MARGIN, spacing=H)
    limit = 12.0
    with ThreadPoolExecutor(max_workers=1) as pool:
        shared = shot_distances(fg, len(specials), limit, pool)
    alone = shot_distances(fg, len(specials), limit)
    for a, b in zip(shared, alone):
        assert np.array_equal(a, b)
    idx = fg.n_lattice + np.arange(len(specials))
    whole = dijkstra(fg.graph, indices=idx)[:, idx]
    direct = shared[2]
    near = whole <= limit
    near[0, :] = near[:, 0] = True  # the start is searched without limit
    assert np.allclose(direct[near], whole[near])
    assert np.isinf(direct[~near]).all()
    assert near.sum() < 0.8 * near.size  # the limit cut some pairs
    assert np.all(shared[0] <= direct + 1e-9) and np.isfinite(shared[0][0]).all()


def test_lattice_for_other_shots_or_spacing_is_not_used(house):
    scene, limits = house
    start = _start(scene, 5.0)
    early = build_lattice(scene, limits, lattice_box(scene, limits, np.zeros((0, 3)), H), start,
                          margin=MARGIN, spacing=H)
    hi = scene.bounds("target")[1]
    beyond = np.vstack([start, _shots(scene), [hi[0] + D_OPT + 3 * H, hi[1], hi[2]]])  # outside the box
    for specials, spacing in ((beyond, H), (np.vstack([start, _shots(scene)]), 1.5 * H)):
        fresh = build_flight_graph(scene, limits, specials, margin=MARGIN, spacing=spacing)
        reused = build_flight_graph(scene, limits, specials, margin=MARGIN, spacing=spacing, lattice=early)
        assert _same_graph(fresh, reused)
        assert fresh.n_lattice != len(early.nodes)  # the prebuilt lattice would have been wrong


def test_lattice_keeps_clear_of_a_wall_next_to_the_house(house):
    """Every lattice node and edge of a prebuilt lattice keeps the security distance plus the
    margin from an obstacle beside the target (a brute-force distance check)."""
    scene, limits = house
    lo, hi = scene.bounds("target")
    wall = box(hi[0] + 4, lo[1], 0, hi[0] + 4.5, hi[1], 8)
    site = scene_from_meshes([scene.targets[0].mesh], [wall])
    lat = build_lattice(site, limits, lattice_box(site, limits, np.zeros((0, 3)), H), _start(scene, 5.0),
                        margin=MARGIN, spacing=H)
    t = np.linspace(0.0, 1.0, 9)[:, None, None]
    mid = lat.nodes[lat.rows] * (1 - t) + lat.nodes[lat.cols] * t
    pts = np.vstack([lat.nodes, mid.reshape(-1, 3)])
    pts = pts[np.linalg.norm(pts - np.clip(pts, wall.bounds[0], wall.bounds[1]), axis=1) < 6.0]
    _, dist, _ = trimesh.proximity.closest_point(wall, pts)
    assert len(pts) > 50 and dist.min() >= SECURITY + MARGIN - 1e-6
