"""Lanes (shots/lanes.py, shots/lane_selection.py) on scenes whose answer we know, the tour that
flies them end to end, and ``--selection lanes`` plans re-checked by independent ray casts and
distance queries; random scenes in test_properties.py."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from coverplan import evaluate, get_camera, load_scene, plan
from coverplan.cli import main
from coverplan.flight.lanes import route_step_shape
from coverplan.flight.tour import lane_costs
from coverplan.planning.settings import PlanSettings
from coverplan.planning.setup import resolve
from coverplan.shots.across_lanes import across_lanes, recess_lanes
from coverplan.shots.candidates import Candidates
from coverplan.shots.lane_selection import MAX_RING_GAP, _fill_rings, ring_pairs, select_lanes
from coverplan.shots.lanes import (
    LANE_SOURCE,
    Lanes,
    band_heights,
    courtyard_lanes,
    facade_lanes,
    lane_steps,
    safe_lanes,
)
from coverplan.shots.roof_lanes import roof_lanes
from coverplan.shots.surface import sample_surface
from coverplan.world.scene import scene_from_meshes
from tests.helpers import MESHES, box
from tests.independent import images, polyline_min_distance

SECURITY = 3.0


def setup_for(scene, **options):
    camera = get_camera("mavic3e")
    return resolve(scene, camera, PlanSettings(gsd=0.004, security=SECURITY, **options))


def test_straight_facade_lanes_face_each_wall_square_on_from_the_standoff():
    """A 15 x 15 x 8 m box: one lane per wall, each photo the standoff out from its wall and
    level, facing it, consecutive photos one step apart with one heading, past both ends."""
    scene = scene_from_meshes([box(0, 0, 0, 15, 15, 8)])
    setup = setup_for(scene)
    d = setup.standoff
    lanes = facade_lanes(scene, setup.camera, setup.limits, d, wrap=False)
    step, _band = lane_steps(setup.camera, d)
    assert lanes.count == 4 and np.all(lanes.cands.source == LANE_SOURCE)
    p, heading = lanes.cands.positions, lanes.cands.heading_deg
    np.testing.assert_allclose(lanes.cands.pitch_deg, 0.0, atol=1e-9)
    # heading 0 looks north (+y): those photos fly the standoff south of the south wall, and so on.
    line = {0.0: (1, -d), 90.0: (0, -d), 180.0: (1, 15.0 + d), 270.0: (0, 15.0 + d)}
    seen = 0
    for h, (axis, at) in line.items():
        facing = np.abs((heading - h + 180.0) % 360.0 - 180.0) < 1e-6
        np.testing.assert_allclose(p[facing, axis], at, atol=1e-6)
        seen += facing.sum()
    assert seen == len(lanes)
    width = setup.camera.footprint(d)[0]
    for k in range(lanes.count):
        run = p[lanes.lane == k]
        steps = np.linalg.norm(np.diff(run, axis=0), axis=1)
        assert steps.max() <= step + 1e-9 and len(np.unique(heading[lanes.lane == k].round(6))) == 1
        along = np.ptp(run[:, :2], axis=0).max()
        assert along > 15.0 + 0.4 * width  # it runs past both corners
    assert polyline_min_distance(p, scene.meshes, 0.5) >= 0.7 * d - 1e-6


@pytest.mark.parametrize("share", [0.0, 0.5, 1.0])
def test_wrapped_lanes_turn_round_each_corner_in_smooth_or_bisector_steps(share):
    """The same box, wrapped: one closed lane per band the standoff from the walls all round
    (round corners), square-on along the walls and facing the corner on the arcs; round the
    smooth corners the heading turns by at most 10 deg from one photo to the next, round the
    others in two 45 deg steps with a photo on the bisector; the whole way round once."""
    scene = scene_from_meshes([box(0, 0, 0, 15, 15, 8)])
    setup = setup_for(scene)
    d = setup.standoff
    lanes = facade_lanes(scene, setup.camera, setup.limits, d, smooth_share=share)
    assert lanes.count == 1 and lanes.closed.tolist() == [True]
    # the last photo is the first again; the pieces (a wall each, cut mid-corner) cover the ring
    c = lanes.cands
    np.testing.assert_allclose(c.positions[-1], c.positions[0])
    assert len(lanes.pieces) == 4 and lanes.pieces[0, 1] == 0 and lanes.pieces[-1, 2] == len(lanes)
    assert np.all(lanes.pieces[1:, 1] == lanes.pieces[:-1, 2] - 1)  # neighbouring pieces share a photo
    p, heading = c.positions[:-1], c.heading_deg[:-1]
    # the distance to the box's footprint is the standoff everywhere (corners included)
    gap = np.hypot(np.maximum(np.maximum(-p[:, 0], p[:, 0] - 15), 0), np.maximum(np.maximum(-p[:, 1], p[:, 1] - 15), 0))
    np.testing.assert_allclose(gap, d, atol=0.05 * d)
    turns = np.abs((np.diff(np.r_[heading, heading[:1]]) + 180.0) % 360.0 - 180.0)
    assert abs(turns.sum() - 360.0) < 1.0 and turns.max() <= 45.0 + 0.5
    turning = turns > 0.5
    smooth_steps = int(np.count_nonzero(turning & (turns <= 10.0)))
    coarse_steps = int(np.count_nonzero(turns > 10.0))
    corners_smooth = round(4 * share)
    assert coarse_steps == 2 * (4 - corners_smooth)
    assert smooth_steps >= 9 * corners_smooth
    # every photo faces the box: the look direction points at the footprint's nearest point
    look = np.column_stack([np.sin(np.radians(heading)), np.cos(np.radians(heading))])
    nearest = np.clip(p[:, :2], 0, 15)
    to = (nearest - p[:, :2]) / np.linalg.norm(nearest - p[:, :2], axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", look, to).min() > np.cos(np.radians(3.0))
    assert polyline_min_distance(p, scene.meshes, 0.5) >= 0.9 * d
    # along a wall (where the heading holds) no further apart than the lane's step
    step, _band = lane_steps(setup.camera, d)
    assert np.linalg.norm(np.diff(p, axis=0), axis=1)[~turning[:-1]].max() <= step + 1e-6


def test_smooth_walk_pivots_at_a_concave_corner():
    """An L's offset has a concave corner: there the facing jumps by 90 deg, and a smooth walk
    turns the camera in place in steps of at most 10 deg instead."""
    from shapely.geometry import Polygon

    from coverplan.shots.lane_rings import smooth_walk

    ell = Polygon([(0, 0), (20, 0), (20, 10), (10, 10), (10, 20), (0, 20)])
    ring = (np.asarray(ell.buffer(4.0, quad_segs=16).exterior.coords), True)
    xy, away = smooth_walk(ring, ell, 3.0, smooth_share=1.0)
    a = np.degrees(np.arctan2(away[:, 1], away[:, 0]))
    turns = np.abs((np.diff(np.r_[a, a[:1]]) + 180.0) % 360.0 - 180.0)
    assert turns.max() <= 10.0
    moved = np.linalg.norm(np.diff(np.vstack([xy, xy[:1]]), axis=0), axis=1)
    pivot = (moved < 0.25) & (turns > 1.0)
    assert pivot.sum() >= 8  # nine steps of 10 deg where the walk hardly moves: the concave corner (14, 14)
    np.testing.assert_allclose(xy[np.flatnonzero(pivot)], [[14.0, 14.0]] * int(pivot.sum()), atol=0.3)


def test_band_heights_cover_the_wall_from_foot_to_top():
    """Bands no further apart than asked, evenly spread, their frames reaching the wall's foot
    and top, none below the minimum altitude."""
    z = band_heights(0.0, 30.0, 10.0, 6.0, 3.0)
    assert np.all(np.diff(z) <= 6.0 + 1e-9) and np.allclose(np.diff(z), np.diff(z)[0])
    assert z[0] - 5.0 <= 0.0 + 1.0 + 1e-9 and z[-1] + 5.0 >= 30.0 - 1.0 - 1e-9
    assert band_heights(0.0, 6.0, 10.0, 6.0, 3.0).tolist() == [3.0]  # one band fits; lifted to the floor
    # One band where a frame spans the wall with half the margin to spare at either end; two
    # where it only just spans it.
    assert band_heights(0.0, 8.0, 8.9, 5.0, 0.0).tolist() == [4.0]
    assert len(band_heights(0.0, 8.0, 8.3, 5.0, 0.0)) == 2


def test_courtyard_lanes_look_across_the_courtyard():
    """Courtyard lanes fly inside a courtyard the standoff does not fit, close to its walls,
    looking across it at the far walls."""
    scene = load_scene(MESHES / "courtyard.obj")  # a 14 x 14 m courtyard (18..32) in a 30 x 30 m block
    setup = setup_for(scene)
    offset = 4.0
    lanes = courtyard_lanes(scene, setup.camera, setup.limits, offset, setup.standoff)
    p = lanes.cands.positions
    assert len(p) >= 8 and np.all((p[:, :2] > 18) & (p[:, :2] < 32))
    look = np.column_stack([np.sin(np.radians(lanes.cands.heading_deg)), np.cos(np.radians(lanes.cands.heading_deg))])
    across = np.einsum("ij,ij->i", look, [25.0, 25.0] - p[:, :2])
    assert np.all(across > 0)  # every photo looks across the courtyard's middle
    assert polyline_min_distance(p, scene.meshes, 0.5) >= 0.9 * offset


def test_roof_lanes_fly_a_nadir_grid_the_standoff_over_the_roof():
    scene = scene_from_meshes([box(0, 0, 0, 20, 10, 6)])
    setup = setup_for(scene)
    samples = sample_surface(scene, setup.spacing)
    lanes = roof_lanes(scene, samples, setup.camera, setup.limits, setup.standoff)
    c = lanes.cands
    assert lanes.count == 1 and len(lanes.pieces) >= 2 and np.all(c.pitch_deg == -90.0)  # a strip a piece
    np.testing.assert_allclose(c.positions[:, 2], 6.0 + setup.standoff, atol=1e-6)
    assert len(np.unique(c.heading_deg.round(6))) == 1
    # lanes along the roof's long side (x): the heading is east or west
    assert abs(np.sin(np.radians(c.heading_deg[0]))) > 0.99
    assert c.positions[:, 0].min() < 2.0 and c.positions[:, 0].max() > 18.0


def test_safe_lanes_cut_a_lane_where_a_photo_is_not_safe():
    lanes = Lanes.runs(Candidates(np.array([[0, -9, 5], [5, -9, 5], [10, -9, 5], [15, -9, 5.0]]), np.zeros(4),
                                  np.zeros(4), np.full(4, LANE_SOURCE, np.int8)), np.zeros(4, dtype=np.int64))
    scene = scene_from_meshes([box(0, 0, 0, 15, 15, 8)], [box(4, -10, 0, 6, -8, 10)])  # a pole at the second
    setup = setup_for(scene)
    kept = safe_lanes(scene, lanes, setup.limits, setup.extra_clearance)
    assert kept.cands.positions[:, 0].tolist() == [0.0, 10.0, 15.0]
    assert kept.lane.tolist() == [0, 1, 1]  # split where the pole's photo was dropped
    assert kept.pieces.tolist() == [[0, 0, 1], [1, 1, 3]]


def _lanes(lane, pieces=None, closed=None):
    lane = np.asarray(lane, dtype=np.int64)
    cands = Candidates(np.zeros((len(lane), 3)), np.zeros(len(lane)), np.zeros(len(lane)),
                       np.full(len(lane), LANE_SOURCE, np.int8))
    if pieces is None:
        return Lanes.runs(cands, lane)
    return Lanes(cands, lane, np.asarray(pieces, dtype=np.int64), np.asarray(closed, dtype=bool))


def test_select_lanes_takes_the_lane_and_trims_its_spare_end():
    """Four samples; lane 0 (three photos) sees samples 0-2 three times over and its last
    photo sample 3 too; two singles see sample 3. min_views 2: the lane is taken, and an end
    photo is kept only while a sample needs it."""
    rows = [[1, 1, 1, 0], [1, 1, 1, 0], [1, 1, 1, 1], [0, 0, 0, 1], [0, 0, 0, 1]]
    vis = sp.csr_matrix(np.array(rows, dtype=float))
    chosen = select_lanes(vis, _lanes([0, 0, 0]), np.ones(4), min_views=2)
    # The first photo is spare (samples 0-2 keep two views without it); the last is not.
    assert chosen.tolist() == [1, 2]
    vis_b = sp.csr_matrix(np.array([[1, 1, 1, 0], [1, 1, 1, 0], [1, 1, 1, 0], [0, 0, 0, 1], [0, 0, 0, 1]], float))
    assert select_lanes(vis_b, _lanes([0, 0, 0]), np.ones(4), min_views=2).tolist() == [1, 2]


def test_select_lanes_takes_pieces_and_a_ring_whole_without_its_repeat():
    """A ring of four photos (rows 0-3, row 4 the first again) in two pieces, each seeing its
    own two samples twice: both pieces are taken, so the ring is flown once round, without
    the repeated photo and untrimmed; with one piece's samples needing no views, only the other
    piece is taken, and the one photo left out between its ends is flown through: the ring whole
    again."""
    ring = _lanes([0, 0, 0, 0, 0], pieces=[[0, 0, 3], [0, 2, 5]], closed=[True])
    rows = [[1, 1, 0, 0], [1, 1, 0, 0], [1, 1, 1, 1], [0, 0, 1, 1], [0, 0, 1, 1]]
    vis = sp.csr_matrix(np.array(rows, dtype=float))
    assert select_lanes(vis, ring, np.ones(4), min_views=2).tolist() == [0, 1, 2, 3]
    need = np.array([2, 2, 0, 0])
    assert select_lanes(vis, ring, np.ones(4), min_views=2, need=need).tolist() == [0, 1, 2, 3]


def test_fill_rings_flies_through_short_gaps_only():
    """A ring of 16 photos (row 16 the first again) taken but for a gap of MAX_RING_GAP photos
    and one of MAX_RING_GAP + 1: the short gap is filled, the long one left; a straight lane's
    gap is never filled."""
    n = 16
    ring = _lanes([0] * (n + 1) + [1] * 10, pieces=[[0, 0, n + 1], [1, n + 1, n + 11]], closed=[True, False])
    taken = np.ones(n + 11, dtype=bool)
    short, long_ = np.arange(1, 1 + MAX_RING_GAP), np.arange(8, 8 + MAX_RING_GAP + 1)
    assert short[-1] < long_[0] - 1 and long_[-1] < n
    taken[short] = taken[long_] = False
    taken[n + 3:n + 5] = False
    filled = _fill_rings(ring, taken)
    assert filled[short].all() and not filled[long_].any() and not filled[n + 3:n + 5].any()
    assert (filled == taken)[np.setdiff1d(np.arange(n + 11), short)].all()


def test_ring_pairs_join_a_ring_across_its_repeated_photo():
    ring = _lanes([0, 0, 0, 0, 0, 1, 1], pieces=[[0, 0, 3], [0, 2, 5], [1, 5, 7]], closed=[True, False])
    pairs = {tuple(p) for p in ring_pairs(ring, np.array([0, 1, 2, 3, 5, 6])).tolist()}
    assert pairs == {(0, 1), (1, 2), (2, 3), (3, 0), (5, 6)}


def test_lane_costs_free_only_between_photos_flown_one_after_the_other():
    pairs = np.array([[0, 1], [1, 2], [3, 4]])
    shots = np.array([2, 0, 1, 4, 3, 5])  # node k + 1 is shot k
    cost = lane_costs(pairs, shots, 7.0)
    free = {(1, 3), (3, 2), (4, 5)}  # candidates 2-1, 0-1, 3-4 as nodes (1-based)
    for a in range(1, 7):
        for b in range(1, 7):
            want = 0.0 if a == b or (a, b) in free or (b, a) in free else 7.0
            assert cost[a, b] == want, (a, b)
    assert np.all(cost[0] == 0) and np.all(cost[:, 0] == 0)


@pytest.fixture(scope="module")
def gabled_lanes():
    scene = load_scene(MESHES / "gabled_house.obj")
    camera = get_camera("mavic3e")
    return scene, plan(scene, camera, gsd=0.004, security=SECURITY, selection="lanes"), \
        plan(scene, camera, gsd=0.004, security=SECURITY)


def test_lanes_plan_is_safe_and_covered_by_independent_checks(gabled_lanes):
    scene, route, _shots = gabled_lanes
    ev = evaluate(route, scene)  # every 0.25 m on samples the planner never saw
    assert ev.safe and ev.coverage_pct >= 99.5
    assert ev.metrics["shot_graph"]["components"] == 1
    assert polyline_min_distance(route.positions, scene.meshes, SECURITY / 10) >= SECURITY
    # Views per sample counted with plain numpy (no Embree, no shared code).
    s = ev.samples
    triangles = np.vstack([m.triangles for m in scene.meshes])
    taken = route.flown_positions()
    views = np.zeros(len(s), dtype=int)
    for k in route.shots:
        views += images(taken[k], route.heading_deg[k], route.pitch_deg[k], route.camera, s.points, s.normals,
                        triangles, route.d_opt, 70.0, offset=scene.epsilon * 4)
    np.testing.assert_array_equal(views, ev.views)
    assert (views[ev.covered] >= 2).all()


def test_lanes_are_flown_end_to_end(gabled_lanes):
    """Most photos are lane photos, and the flight turns the camera less often than the
    shot-by-shot plan of the same house."""
    _scene, route, shots = gabled_lanes
    assert route.metrics["lane_shots"] >= 0.5 * route.shot.sum() and route.metrics["lanes"] >= 2
    assert route.params["selection"] == "lanes" and route.params["edge_views"]
    assert route_step_shape(route)[0] > route_step_shape(shots)[0] + 5.0


def test_lanes_take_at_most_a_fifth_more_photos_than_shots(gabled_lanes):
    """The lanes plan of the house takes no more than a fifth more photos than its
    shot-by-shot plan (its edge views come on top of the lanes)."""
    _scene, route, shots = gabled_lanes
    assert route.shot.sum() <= 1.2 * shots.shot.sum()


def test_selection_on_the_command_line(tmp_path, capsys):
    out = tmp_path / "house.json"
    code = main(["plan", str(MESHES / "gabled_house.obj"), "--camera", "mavic3e", "--gsd", "0.004", "--security", "3",
                 "--selection", "lanes", "--forward-overlap", "0.75", "-o", str(out), "-q"])
    assert code == 0 and out.exists()
    for bad in (["--selection", "rows"], ["--forward-overlap", "0.99"], ["--side-overlap", "-0.1"]):
        try:
            code = main(["plan", str(MESHES / "gabled_house.obj"), "--camera", "mavic3e", "--gsd", "0.004",
                         "--security", "3", *bad, "-o", str(tmp_path / "x.json"), "-q"])
        except SystemExit as exc:  # argparse's own refusal
            code = exc.code
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and "Traceback" not in err[0], bad


def test_across_lanes_look_at_the_sides_of_the_notches_from_over_the_far_wing():
    """The H (wings 16..21 and 29..34, notches 8 m wide between them, 8 m tall): one lane over
    each wing's inner edge, the nearest distance above the top, looking back across the notches
    at the far wing's inner walls; an independent ray cast from each photo's centre of view
    meets a notch's side wall first. A box has no wall facing another: no lane."""
    scene = load_scene(MESHES / "h_prism.obj")
    setup = setup_for(scene)
    nearest = 1.2 * (setup.limits.security + setup.extra_clearance)
    lanes = safe_lanes(scene, across_lanes(scene, setup.camera, setup.limits, setup.standoff, nearest),
                       setup.limits, setup.extra_clearance)
    p, heading = lanes.cands.positions, lanes.cands.heading_deg
    assert lanes.count == 2 and len(p) >= 6
    np.testing.assert_allclose(p[:, 2], 8.0 + nearest, atol=1e-6)
    east = np.abs((heading - 90.0 + 180.0) % 360.0 - 180.0) < 1e-6  # over the west wing, looking east
    west = np.abs((heading - 270.0 + 180.0) % 360.0 - 180.0) < 1e-6
    assert np.all(east | west) and east.any() and west.any()
    np.testing.assert_allclose(p[east, 0], 21.0, atol=1e-6)  # over the far wing's top edge
    np.testing.assert_allclose(p[west, 0], 29.0, atol=1e-6)
    # Points on the notches' side walls, imaged (independent frustum, incidence, range and
    # occlusion test) by the lane on the far side.
    y, z = np.meshgrid(np.r_[np.linspace(17.5, 22.75, 6), np.linspace(27.25, 32.5, 6)], np.linspace(0.5, 7.5, 5))
    mesh = scene.meshes[0]
    for lane_photos, wall_x, normal_x in ((east, 29.0, -1.0), (west, 21.0, 1.0)):
        pts = np.column_stack([np.full(y.size, wall_x), y.ravel(), z.ravel()])
        normals = np.tile([normal_x, 0.0, 0.0], (len(pts), 1))
        views = sum(images(p[i], heading[i], lanes.cands.pitch_deg[i], setup.camera, pts, normals, mesh.triangles,
                           setup.limits.d_opt, setup.limits.max_incidence_deg).astype(int)
                    for i in np.flatnonzero(lane_photos))
        assert views.min() >= 2 and views.mean() >= 2.5
    box_scene = scene_from_meshes([box(0, 0, 0, 15, 15, 8)])
    assert len(across_lanes(box_scene, setup.camera, setup.limits, setup.standoff, nearest)) == 0


def test_recess_lanes_fly_across_the_mouth_of_each_notch():
    """The H's notches are 5.75 m deep: one level lane per notch, the depth and the nearest
    distance out from its back wall, facing it, each photo the nearest distance clear of every
    surface (independent distance query); none on a box."""
    scene = load_scene(MESHES / "h_prism.obj")
    setup = setup_for(scene)
    nearest = 1.2 * (setup.limits.security + setup.extra_clearance)
    lanes = safe_lanes(scene, recess_lanes(scene, setup.camera, setup.limits, nearest), setup.limits,
                       setup.extra_clearance)
    p, heading = lanes.cands.positions, lanes.cands.heading_deg
    assert lanes.count == 2
    np.testing.assert_allclose(lanes.cands.pitch_deg, 0.0, atol=1e-9)
    north = np.abs((heading + 180.0) % 360.0 - 180.0) < 1e-6  # south of the south notch, looking north
    np.testing.assert_allclose(p[north, 1], 23.0 - 5.75 - nearest, atol=1e-6)
    np.testing.assert_allclose(p[~north, 1], 27.0 + 5.75 + nearest, atol=1e-6)
    assert np.abs((heading[~north] - 180.0 + 180.0) % 360.0 - 180.0).max() < 1e-6
    assert polyline_min_distance(p[north], scene.meshes, 0.25) >= nearest - 1e-6
    box_scene = scene_from_meshes([box(0, 0, 0, 15, 15, 8)])
    assert len(recess_lanes(box_scene, setup.camera, setup.limits, nearest)) == 0
    # The L's inner walls lie as far inside its hull, but each meets a wall at one end only:
    # its open end is flown round by the rings' wraps, so no recess lane.
    l_scene = load_scene(MESHES / "l_prism.obj")
    assert len(recess_lanes(l_scene, setup.camera, setup.limits, nearest)) == 0


def test_the_h_flies_its_notches_as_lanes_and_stays_safe_and_covered():
    """The H's lanes plan photographs the notches' sides from the across lanes (photos over the
    wings' inner edges, level with nothing, looking east or west and down), and is covered
    and safe by the evaluator's own samples and an independent distance query."""
    scene = load_scene(MESHES / "h_prism.obj")
    route = plan(scene, get_camera("mavic3e"), gsd=0.004, security=SECURITY, selection="lanes")
    ev = evaluate(route, scene)
    assert ev.safe and ev.coverage_pct >= 99.5 and ev.metrics["shot_graph"]["components"] == 1
    assert polyline_min_distance(route.positions, scene.meshes, SECURITY / 10) >= SECURITY
    p, heading, pitch = route.positions[route.shots], route.heading_deg[route.shots], route.pitch_deg[route.shots]
    over_wing = (np.abs(p[:, 0] - 21.0) < 0.5) | (np.abs(p[:, 0] - 29.0) < 0.5)
    across = over_wing & (p[:, 2] > 8.0 + SECURITY) & (pitch < -20.0) & \
        (np.abs(np.cos(np.radians(heading))) < 0.05)  # looking east or west
    assert across.sum() >= 6
