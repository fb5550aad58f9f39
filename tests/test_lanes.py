"""Flights that read as lanes: the step figures, and square-on views (issue 33, part 2)."""

import json

import numpy as np
import pytest

from coverplan import evaluate, get_camera, load_scene, plan
from coverplan.cli import main
from coverplan.flight.lanes import route_step_shape, smooth_ceiling, step_shape
from coverplan.flight.tour import DEFAULT_REAIM_STEPS, DEFAULT_REVERSAL_STEPS
from coverplan.shots.candidates import facade_rings
from coverplan.shots.limits import scene_limits
from coverplan.world.scene import scene_from_meshes
from tests.helpers import MESHES, box
from tests.independent import polyline_min_distance

SECURITY = 3.0


def test_step_figures_on_flights_whose_answer_is_known():
    # Along a wall at one heading: every step smooth, never turning back.
    x = np.arange(6.0)
    lane = np.column_stack([x, np.zeros(6), np.full(6, 5.0)])
    assert step_shape(lane, np.full(6, 90.0), np.zeros(6)) == (100.0, 0.0)
    # 355 -> 5 deg is a 10 deg turn across north (smooth); 5 -> 16 is not; a 6 deg pitch step is not.
    smooth, _ = step_shape(lane[:4], [355.0, 5.0, 16.0, 16.0], [0.0, 0.0, 0.0, -6.0])
    assert smooth == pytest.approx(100.0 / 3)
    # There and back twice: the photos at x = 2 and x = 0 turn the drone round.
    there_back = np.array([[0, 0, 5], [1, 0, 5], [2, 0, 5], [1, 0, 5], [0, 0, 5], [1, 0, 5]], float)
    _, reversals = step_shape(there_back, np.zeros(6), np.zeros(6))
    assert reversals == pytest.approx(100.0 * 2 / 6)
    # A right angle is no reversal; a photo taken twice at one place is skipped, not a turn.
    corner = np.array([[0, 0, 5], [1, 0, 5], [1, 0, 5], [1, 1, 5]], float)
    assert step_shape(corner, np.zeros(4), np.zeros(4))[1] == 0.0


def box_rings(view_tilts: str):
    """The façade-ring candidates 8 m out from a 20 x 10 x 8 m box, and the camera."""
    scene = scene_from_meshes([box(0, 0, 0, 20, 10, 8)], [])
    camera = get_camera("phantom4pro")
    limits = scene_limits(scene, security=SECURITY, d_opt=12.0, max_incidence_deg=70.0, min_altitude=SECURITY,
                          pitch_range_deg=(-90.0, 30.0), vfov_deg=camera.vfov_deg)
    return facade_rings(scene, camera, limits, 8.0, view_tilts=view_tilts), camera


def test_the_smooth_ceiling_bounds_every_order():
    """Headings 0, 8, 16 chain into one group (each step 8 deg), 90 and 95 into another, 200
    stands alone: at most 6 - 3 = 3 of the 5 steps can be smooth, and the best order has 3."""
    heading = np.array([90.0, 0.0, 200.0, 16.0, 95.0, 8.0])
    pitch = np.zeros(6)
    assert smooth_ceiling(heading, pitch) == pytest.approx(60.0)
    best = [1, 5, 3, 0, 4, 2]
    assert step_shape(np.arange(18.0).reshape(6, 3), heading[best], pitch[best])[0] == pytest.approx(60.0)
    rng = np.random.default_rng(3)
    for _ in range(20):  # no order beats the ceiling
        order = rng.permutation(6)
        assert step_shape(np.arange(18.0).reshape(6, 3), heading[order], pitch[order])[0] <= 60.0 + 1e-9
    # The 8 deg photo pitched 6 deg lower breaks the chain: 0, 8 and 16 fall apart, five groups.
    assert smooth_ceiling(heading, np.array([0.0, 0.0, 0.0, 0.0, 0.0, -6.0])) == pytest.approx(20.0)
    assert smooth_ceiling([10.0], [0.0]) == 100.0


def test_square_ring_candidates_face_their_wall_square_on():
    square, _ = box_rings("square")
    varied, _ = box_rings("varied")
    assert len(varied) == 3 * len(square)
    p, h = square.positions, square.heading_deg
    # Beside a wall (not on the rounded corners of the offset ring) a camera looks straight at it.
    south = (p[:, 1] < -7.9) & (p[:, 0] > 0) & (p[:, 0] < 20)
    east = (p[:, 0] > 27.9) & (p[:, 1] > 0) & (p[:, 1] < 10)
    assert south.sum() >= 3 and east.sum() >= 2
    assert np.allclose(h[south], 0.0, atol=1e-6) and np.allclose(h[east], 270.0, atol=1e-6)
    assert np.allclose(square.pitch_deg, 0.0)


@pytest.fixture(scope="module")
def gabled():
    """The gabled house's plans without edge views, so each comparison isolates its own option:
    the edge views' photos, each turned half-way between two faces, interleave with the walls'
    and leave the re-aim cost 8 pp of smooth steps to gain (25 % to 33 %) where it gains 15+."""
    scene = load_scene(MESHES / "gabled_house.obj")
    camera = get_camera("phantom4pro")
    kw = dict(gsd=0.004, security=SECURITY, edge_views=False)
    routes = {tilts: plan(scene, camera, view_tilts=tilts, **kw) for tilts in ("varied", "square")}
    routes["shortest"] = plan(scene, camera, reversal_steps=0.0, reaim_steps=0.0, **kw)
    routes["no re-aim cost"] = plan(scene, camera, reaim_steps=0.0, **kw)
    routes["square, no re-aim cost"] = plan(scene, camera, view_tilts="square", reaim_steps=0.0, **kw)
    return scene, routes


def _shot_keys(route):
    rows = route.shots
    return np.unique(np.round(np.column_stack([route.positions[rows], route.heading_deg[rows],
                                               route.pitch_deg[rows]]), 6), axis=0)


def test_the_tour_trades_a_little_path_for_fewer_reversals(gabled):
    scene, routes = gabled
    ours, shortest = routes["no re-aim cost"], routes["shortest"]
    # The same photos in another order: only the tour changed.
    assert np.array_equal(_shot_keys(ours), _shot_keys(shortest))
    # Six typical steps: the median distance from a photo to its nearest by the flight graph.
    assert ours.params["reversal_steps"] == DEFAULT_REVERSAL_STEPS == 6.0 and shortest.params["reversal_m"] == 0.0
    assert 6.0 <= ours.params["reversal_m"] <= 60.0
    _, turned = route_step_shape(ours)
    _, plain = route_step_shape(shortest)
    assert turned <= 0.6 * plain
    assert ours.path_length <= 1.35 * shortest.path_length
    # Fewer stops: more photos in passing, and no slower flown through.
    assert ours.metrics["fly_through"]["photos_in_passing"] > shortest.metrics["fly_through"]["photos_in_passing"]
    assert ours.metrics["fly_through"]["minutes"] <= shortest.metrics["fly_through"]["minutes"]
    assert evaluate(ours, scene).safe
    assert polyline_min_distance(ours.positions, scene.meshes, SECURITY / 10) >= SECURITY


def test_the_tour_flies_photos_that_look_the_same_way_one_after_another(gabled):
    scene, routes = gabled
    ours, plain = routes["varied"], routes["no re-aim cost"]
    assert np.array_equal(_shot_keys(ours), _shot_keys(plain))
    assert ours.params["reaim_steps"] == DEFAULT_REAIM_STEPS == 2.0 and plain.params["reaim_m"] == 0.0
    # Both costs are counted in the same typical step.
    assert ours.params["reaim_m"] == pytest.approx(ours.params["reversal_m"] / 3.0, abs=1e-3)
    smooth, reversals = route_step_shape(ours)
    plain_smooth, plain_reversals = route_step_shape(plain)
    assert smooth >= plain_smooth + 15.0 and reversals <= plain_reversals
    assert ours.path_length <= 1.25 * plain.path_length
    assert ours.metrics["fly_through"]["minutes"] <= 1.1 * plain.metrics["fly_through"]["minutes"]
    assert evaluate(ours, scene).safe


def test_a_negative_reversal_cost_is_refused_in_one_line(tmp_path, capsys):
    code = main(["plan", str(MESHES / "square_prism.obj"), "--gsd", "0.004", "--security", "3", "--camera",
                 "phantom4pro", "--reversal-cost", "-1", "-o", str(tmp_path / "r.json")])
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert "reversal cost (--reversal-cost)" in err and len(err.splitlines()) == 1
    code = main(["plan", str(MESHES / "square_prism.obj"), "--gsd", "0.004", "--security", "3", "--camera",
                 "phantom4pro", "--reaim-cost", "nan", "-o", str(tmp_path / "r.json")])
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert "re-aim cost (--reaim-cost)" in err and len(err.splitlines()) == 1


def test_square_views_keep_every_guarantee_and_fly_smoother(gabled):
    scene, routes = gabled
    square, varied = routes["square"], routes["varied"]
    ev = evaluate(square, scene)  # fresh samples every 0.25 m, the rules re-checked
    m = ev.metrics
    assert m["coverage_pct"] >= 99.5 and square.metrics["planned_coverage_pct"] <= m["coverage_pct"] + 0.1
    assert m["safe"] and polyline_min_distance(square.positions, scene.meshes, SECURITY / 10) >= SECURITY
    assert m["shot_graph"]["components"] == 1
    smooth, reversals = route_step_shape(square)
    assert (smooth, reversals) == (square.metrics["smooth_steps_pct"], square.metrics["reversals_per_100"])
    # Photos along a wall share a heading: many more smooth steps than the varied views give in a
    # tour that does not prefer them, and more than the varied views in one that does.
    assert route_step_shape(routes["square, no re-aim cost"])[0] >= route_step_shape(routes["no re-aim cost"])[0] + 15.0
    assert smooth > route_step_shape(varied)[0]
    assert square.params["view_tilts"] == "square" and "view_tilts" not in varied.params


def test_view_tilts_flag_reaches_the_route_and_the_summary(tmp_path, capsys):
    out = tmp_path / "route.json"
    code = main(["plan", str(MESHES / "square_prism.obj"), "--gsd", "0.004", "--security", "3", "--camera",
                 "phantom4pro", "--view-tilts", "square", "-o", str(out), "-v"])
    assert code == 0
    shown = capsys.readouterr().out  # the tour's figures are the planner's: under -v
    assert "view tilts square, a reversal costs the tour" in shown and "m (6 steps)" in shown
    assert "a step that turns the camera" in shown and "m (2 steps)" in shown
    assert json.loads(out.read_text())["params"]["view_tilts"] == "square"


def test_corner_ring_candidates_are_tilted_only_where_the_ring_turns():
    square, _ = box_rings("square")
    corners, camera = box_rings("corners")
    varied, _ = box_rings("varied")
    assert len(square) < len(corners) < len(varied)
    # The square-on views are all there; a tilted one stands where the ring rounds a corner or
    # within two ring steps of it, never mid-wall.
    key = np.round(np.column_stack([corners.positions, corners.heading_deg]), 6)
    assert len(np.unique(key, axis=0)) == len(corners)
    p = corners.positions
    inward = np.column_stack([np.sin(np.radians(corners.heading_deg)), np.cos(np.radians(corners.heading_deg))])
    nearest = np.clip(p[:, :2], [0, 0], [20, 10]) - p[:, :2]
    off = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", inward, nearest / np.linalg.norm(nearest, axis=1,
                                                                                            keepdims=True)), -1, 1)))
    tilted = off > 1.0
    assert tilted.any()
    beside = (p[:, 0] > 0) & (p[:, 0] < 20) | (p[:, 1] > 0) & (p[:, 1] < 10)
    step = camera.footprint(8.0)[0] / 4.0
    # Mid-wall: more than three ring steps from both ends of the wall.
    mid = beside & (np.where((p[:, 0] > 0) & (p[:, 0] < 20), np.minimum(p[:, 0], 20 - p[:, 0]),
                             np.minimum(p[:, 1], 10 - p[:, 1])) > 3 * step)
    assert not (tilted & mid).any()


def test_fewer_tilts_warn_that_links_across_corners_need_a_field_simulate(gabled):
    _, routes = gabled
    assert not any("view tilts" in n for n in routes["varied"].extra["notes"])
    assert any(n.startswith("WARNING view tilts square") and "simulate --conditions field" in n
               for n in routes["square"].extra["notes"])
