"""The planner on scenes whose answer we know, judged by the evaluator and by independent checks."""

from __future__ import annotations

import numpy as np
import pytest

from coverplan import PlanningError, Route, evaluate, get_camera, load_scene, plan
from coverplan.cli import main
from coverplan.shots.surface import CLASS_NAMES
from coverplan.shots.visibility import widest_pair_angle
from coverplan.world.scene import scene_from_meshes
from tests.helpers import MESHES, box, gsd_for
from tests.independent import images, polyline_min_distance

SECURITY = 3.0
SCENES = {
    "square": ("square_prism.obj", []),
    "l": ("l_prism.obj", []),
    "h": ("h_prism.obj", []),
    "triangle": ("triangle_prism.obj", []),
    "prism": ("thesis_prism.obj", []),
    "ring": ("ring_prism.obj", []),
    "pyramid": ("pyramid.obj", []),
    "fig411": ("thesis_prism.obj", ["fig411_obstacles.obj"]),
    "gabled": ("gabled_house.obj", []),
    "courtyard": ("courtyard.obj", []),
    "flush": ("flush_target.obj", ["flush_obstacle.obj"]),
    "chapel": ("chapel.obj", []),  # a 24 m tower with a spire beside a gabled nave
}


def load(name):
    target, obstacles = SCENES[name]
    return load_scene(MESHES / target, [MESHES / o for o in obstacles])


@pytest.fixture(scope="module")
def planned():
    """Each sample scene planned once per test process, when a test first asks for it (thesis
    settings: d_opt 7 m, security 3 m, 80 deg FOV): the workers share the scenes out."""
    from coverplan import get_camera

    class Plans(dict):
        def __missing__(self, name):
            camera = get_camera("thesis80")
            scene = load(name)
            route = plan(scene, camera, gsd=gsd_for(camera, 7.0), security=SECURITY)
            self[name] = (scene, route, evaluate(route, scene))
            return self[name]

    return Plans()


@pytest.mark.parametrize("name", list(SCENES))
def test_sample_scene_is_covered_and_safe(planned, name):
    scene, route, ev = planned[name]
    m = ev.metrics
    # Judged every 0.25 m on samples the planner never saw; its own figure may not claim more.
    assert m["sample_spacing_m"] == 0.25
    assert m["coverage_pct"] >= 99.5, m["coverage_pct"]
    assert route.metrics["planned_coverage_pct"] <= m["coverage_pct"] + 0.1
    assert m["p_outliers"] <= 0.001 * m["samples"]  # seen twice but never triangulated: rare strays
    assert m["safe"] and m["min_clearance_m"] >= SECURITY
    assert m["altitude_violations"] == 0 and m["orientation_mismatches"] == 0
    assert m["returns_to_start"]
    # independent of FCL: trimesh distances every 0.3 m along the flight
    assert polyline_min_distance(route.positions, scene.meshes, SECURITY / 10) >= SECURITY
    # every selected view is flown: shots sharing a position (different headings) are not merged
    assert route.shot.sum() == m["shots"] == route.metrics["selected_views"]
    legs = route.leg
    assert legs[0] == "initial" and legs[-1] == "final" and route.shot[legs.index("coverage")]


def test_mean_fine_coverage(planned):
    """The bar for the default plans (docs/design.md): mean coverage at 0.25 m at least 99.9 %."""
    assert np.mean([ev.coverage_pct for _s, _r, ev in planned.values()]) >= 99.9


@pytest.mark.parametrize("name", ["square", "fig411"])
def test_coverage_rechecked_by_brute_force(planned, name):
    """Count views per sample with plain numpy (no Embree, no shared code) and compare."""
    scene, route, ev = planned[name]
    s = ev.samples
    triangles = np.vstack([m.triangles for m in scene.meshes])
    hits, rays = [], []
    taken = route.flown_positions()  # where the photos are taken: off the waypoint where it flies through
    for k in route.shots:
        ok = images(taken[k], route.heading_deg[k], route.pitch_deg[k], route.camera, s.points,
                    s.normals, triangles, route.d_opt, 70.0, offset=scene.epsilon * 4)
        idx = np.flatnonzero(ok)
        hits.append(idx)
        v = taken[k] - s.points[idx]
        rays.append(v / np.linalg.norm(v, axis=1, keepdims=True))
    pt = np.concatenate(hits)
    views = np.bincount(pt, minlength=len(s))
    widest = widest_pair_angle(pt, np.vstack(rays), len(s))
    covered = (views >= 2) & (widest >= 5.0)
    assert covered[ev.covered].all()
    np.testing.assert_array_equal(views, ev.views)


def test_small_obstacle_between_slices_leaves_no_gap(planned):
    """Thesis Figure 4.11: the wall behind the small floating obstacle is covered."""
    _, _, ev = planned["fig411"]
    pts = ev.samples.points
    behind = (np.abs(pts[:, 1] - 18.5) < 1e-6) & (np.abs(pts[:, 0] - 25) < 2) & (np.abs(pts[:, 2] - 10) < 2)
    assert behind.sum() > 5
    assert ev.covered[behind].all()


def test_planner_claims_recheck(planned):
    """On the planner's own check samples, the evaluator covers everything the planner does not
    list, finds unreachable what it lists as such, and the planner's figure is not above its
    (the planner counts a view only with 1 % to spare)."""
    from coverplan.shots.check_samples import planner_check_samples
    for name, (scene, route, _ev) in planned.items():
        ev = evaluate(route, scene, samples=planner_check_samples(scene, route))
        listed = {tuple(np.round(u["position"], 6)) for u in route.uncovered}
        claimed = np.array([tuple(np.round(p, 6)) not in listed for p in ev.samples.points])
        assert ev.covered[claimed].all(), name
        said_unreachable = np.array([not u["reachable"] for u in route.uncovered], dtype=bool)
        assert said_unreachable.sum() == (~ev.reachable).sum(), name
        assert route.metrics["planned_coverage_pct"] <= ev.coverage_pct + 1e-9, name


def test_shots_near_the_lp_bound(planned):
    """The covering shots (with their sharp views, chosen with them) stay near the LP bound; the SfM
    rule's linking shots and the edge views every plan takes come on top (and redundant shots go:
    counted back to find what the cover chose)."""
    for name, (_scene, route, _ev) in planned.items():
        bound = route.metrics["lp_lower_bound_shots"]
        m = route.metrics
        covering = (m["selected_views"] + m["redundant_shots_dropped"] + m["trimmed_shots"] - m["linking_shots"]
                    - m["repair_shots"] - m["sharp_view_shots"] - m["edge_view_shots"])
        assert bound is not None and covering <= 1.3 * bound, (name, covering, bound)
        assert route.metrics["linking_shots"] <= covering, name


def test_obstacle_hiding_part_of_a_wall_plans_the_rest(thesis_camera):
    wall = box(0, 0, 0, 16, 8, 10)
    shed = box(5, -2.3, 0, 11, -0.3, 6)  # 0.3 m from the wall: nothing can look behind it
    scene = scene_from_meshes([wall], [shed])
    route = plan(scene, thesis_camera, gsd=gsd_for(thesis_camera, 7.0), security=SECURITY)
    ev = evaluate(route, scene)
    # The strip just above the shed's roof is reachable only by grazing views: a few samples
    # stay short, and the planner says why.
    assert ev.metrics["coverage_pct"] >= 99.5
    assert ev.safe
    short = [u for u in route.uncovered if u["reachable"]]
    assert all(u["reason"] != "not covered by the selected shots" for u in short)
    assert sum(u["area_m2"] for u in short) < 0.005 * route.metrics["reachable_area_m2"]
    hidden = [u for u in route.uncovered if "obstacle" in u["reason"]]
    assert len(hidden) >= 10
    where = np.array([u["position"] for u in hidden])
    assert (np.abs(where[:, 1]) < 1e-6).all() and (where[:, 0] > 4.5).all() and (where[:, 0] < 11.5).all()
    # what the planner lists as unreachable is what the evaluator finds unreachable (by area)
    listed = sum(u["area_m2"] for u in route.uncovered if not u["reachable"])
    assert listed == pytest.approx(ev.metrics["unreachable_area_m2"], rel=0.1)


def test_claim_holds_beside_a_block_flush_against_a_wall():
    """A 1 m block 9 cm off a wall (the slow property test's find): the wall behind it is
    hidden, and the strip beside its outline is imaged from grazing views that a few
    centimetres further in are cut off. The planner claimed 100 % there and the evaluator
    found 99.89 %; the samples at that edge are now judged from points around them too."""
    scene = scene_from_meshes([box(-1.5, -1.5, 0, 1.5, 1.5, 4)], [box(-2.34375, 0.0, 0.0, -1.59375, 1.0, 1.0)])
    route = plan(scene, get_camera("mavic3e"), gsd=0.0007998002810858792, security=1.0, min_altitude=1.0,
                 lp_time_limit=5)
    ev = evaluate(route, scene)
    assert ev.safe
    assert route.metrics["planned_coverage_pct"] <= ev.metrics["coverage_pct"] + 0.1
    edge = np.array([u["position"] for u in route.uncovered if u["reason"].startswith("at the edge of surface")])
    assert len(edge)
    # on the west wall, around the block's outline (y 0..1, up to z 1), not elsewhere
    assert np.allclose(edge[:, 0], -1.5) and (edge[:, 1] > -0.5).all() and (edge[:, 1] < 1.5).all()
    assert (edge[:, 2] < 1.5).all()


def test_a_plan_whose_lp_ran_out_of_time_warns():
    """The LP's limit is wall time: past it the shots are chosen without it and differ with
    the machine's speed (the courtyard at 1.5 mm/px took other shots under load at the old
    20 s default). The plan says so instead of handing out a machine-dependent route silently."""
    scene = scene_from_meshes([box(0, 0, 0, 6, 4, 5)])
    cam = get_camera("phantom4pro")
    cut = plan(scene, cam, gsd=0.005, security=3.0, lp_time_limit=1e-9)
    assert any(n.startswith("WARNING view selection: the LP stopped at its time limit")
               and "--lp-time-limit" in n for n in cut.extra["notes"])
    assert "lp_lower_bound_shots" not in cut.metrics
    full = plan(scene, cam, gsd=0.005, security=3.0)
    assert not any("the LP stopped" in n for n in full.extra["notes"])
    assert full.metrics["lp_lower_bound_shots"] > 0


def test_walls_seen_only_between_obstacles():
    # A scene the property test drew: a slab through the roof, a block floating over the east
    # wall's foot, a shed 7.6 m off the north wall (under twice the 3.86 m security distance).
    # The safe views of the north wall's foot and of the east wall under the block fill cones
    # a few degrees wide, at 5.3-6.1 m of the 6.18 m reach. The planner's first repair round
    # left 1.5 % of the surface short (98.51 % at 0.25 m); probing again around the views
    # found and completing pairs the greedy cannot see raise it to 99.33 %. Planned without the
    # pose margin: its narrower frame leaves cones that narrow emptier (98.7 % by the evaluator,
    # every missed sample listed), and this test is about the repair's probing.
    target = box(-4.172677675662499, -2.4125593766964437, 0.0, 4.172677675662499, 2.4125593766964437,
                 9.091692300123434)
    obstacles = [box(-2.1016279834170426, 10.0, 0.0, 0.6500905621490713, 13.228349111508422, 5.414540963725787),
                 box(3.256837610461101, 0.0, 3.5409274062173495, 7.23221991669228, 3.5, 14.01456054084392),
                 box(0.0, 1.7556409173283747, 0.0, 2.5627088370161095, 2.2512730299054153, 14.0)]
    scene = scene_from_meshes([target], obstacles)
    route = plan(scene, get_camera("mavic3e"), gsd=0.0016465088490906464, security=3.8599687510155682,
                 min_altitude=2.345, lp_time_limit=5, pose_margin="none")
    ev = evaluate(route, scene)
    assert ev.safe
    assert ev.metrics["coverage_pct"] >= 99.0
    assert route.metrics["planned_coverage_pct"] <= ev.metrics["coverage_pct"] + 0.1
    # Every check sample some pair of safe candidates covers is covered; the rest say why.
    reasons = {u["reason"] for u in route.uncovered if u["reachable"]}
    assert "not covered by the selected shots" not in reasons and reasons


def test_route_file_round_trip(planned, tmp_path):
    _scene, route, _ev = planned["gabled"]
    path = route.save(tmp_path / "r.json")
    back = Route.load(path)
    np.testing.assert_allclose(back.positions, route.positions, atol=1e-4)
    np.testing.assert_array_equal(back.shot, route.shot)
    assert back.leg == route.leg and back.params == route.params
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left behind
    with pytest.raises(Exception, match="--force"):
        route.save(path, force=False)


def cli(capsys, *args):
    try:
        code = main([str(a) for a in args])
    except SystemExit as exc:
        code = exc.code
    return code, capsys.readouterr().err


@pytest.mark.parametrize("extra, words", [
    (["--gsd", "0.0005"], ["finest gsd"]),  # d_opt 1.8 m < security 3 m
    (["--gsd", "0.004", "--start", "20", "20", "4"], ["inside", "l_prism"]),
    (["--gsd", "0.004", "--start", "13", "25", "4"], ["closer than the security distance"]),
])
def test_impossible_settings_end_with_one_line(capsys, tmp_path, extra, words):
    args = ["plan", MESHES / "l_prism.obj", "--camera", "phantom4pro", "--security", "3",
            "-o", tmp_path / "r.json", "-q"] + extra
    code, err = cli(capsys, *args)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    for w in words:
        assert w in err.lower()
    assert not (tmp_path / "r.json").exists()


def test_target_with_no_surface(capsys, tmp_path):
    floor = tmp_path / "floor.obj"
    floor.write_text("v 0 0 0\nv 10 0 0\nv 10 10 0\nv 0 10 0\nf 1 3 2\nf 1 4 3\n")  # faces down, on the ground
    code, err = cli(capsys, "plan", floor, "--camera", "phantom4pro", "--gsd", "0.004", "--security", "3",
                    "-o", tmp_path / "r.json", "-q")
    assert code == 2 and "no surface" in err and len(err.strip().splitlines()) == 1


def test_plan_refuses_to_overwrite(capsys, tmp_path):
    out = tmp_path / "r.json"
    out.write_text("{}")
    code, err = cli(capsys, "plan", MESHES / "gabled_house.obj", "--camera", "phantom4pro", "--gsd", "0.004",
                    "--security", "3", "-o", out, "-q")
    assert code == 2 and "--force" in err
    assert out.read_text() == "{}"


def test_start_is_where_the_flight_begins_and_ends(thesis_camera):
    scene = load("square")
    start = np.array([0.0, 50.0, 3.0])
    route = plan(scene, thesis_camera, gsd=gsd_for(thesis_camera, 7.0), security=SECURITY, start=start)
    np.testing.assert_allclose(route.positions[0], start)
    np.testing.assert_allclose(route.positions[-1], start)


def test_impossible_gsd_error_names_the_finest_possible(thesis_camera):
    scene = load("square")
    with pytest.raises(PlanningError, match="finest GSD"):
        plan(scene, thesis_camera, gsd=gsd_for(thesis_camera, 2.5), security=SECURITY)


def test_same_position_different_headings_stay_two_shots(thesis_camera, tmp_path):
    """Thesis Table 4.1 lost one of two shots at the same spot; the route keeps both."""
    scene = load("square")
    p = np.array([25.0, 12.0, 4.0])
    route = Route([p + [0, -5, 0], p, p, p + [0, -5, 0]], [False, True, True, False], [0, 0, 30, 0],
                  [0, 0, 0, 0], ["initial", "coverage", "coverage", "final"], thesis_camera,
                  {"gsd_m": gsd_for(thesis_camera, 7.0), "security_m": SECURITY})
    back = Route.load(route.save(tmp_path / "two.json"))
    assert back.shot.sum() == 2 and list(back.heading_deg[1:3]) == [0, 30]
    ev = evaluate(back, scene)
    assert ev.metrics["shots"] == 2 and ev.metrics["db_viewpoints_m"]["min"] == 0.0


def test_strict_evaluation_fails_unsafe_routes(capsys, tmp_path, thesis_camera):
    p = np.array([25.0, 16.5, 4.0])  # 1 m from the square prism's south wall
    route = Route([p, p], [True, False], [0, 0], [0, 0], ["coverage", "final"], thesis_camera,
                  {"gsd_m": gsd_for(thesis_camera, 7.0), "security_m": SECURITY})
    path = route.save(tmp_path / "close.json")
    code, _err = cli(capsys, "evaluate", path, "--target", MESHES / "square_prism.obj", "--strict")
    assert code == 1
    code, _err = cli(capsys, "evaluate", path, "--target", MESHES / "square_prism.obj")
    assert code == 0


def test_only_roof_covers_the_roof_with_fewer_shots(capsys, tmp_path, planned):
    """`--only roof`: every roof sample imaged twice (independent check), fewer shots than all."""
    out = tmp_path / "roof.json"
    code, err = cli(capsys, "plan", MESHES / "gabled_house.obj", "--camera", "thesis80", "--gsd",
                    gsd_for(planned["gabled"][1].camera, 7.0), "--security", SECURITY, "--only", "roof",
                    "-o", out, "-q")
    assert code == 0, err
    scene, full, _ = planned["gabled"]
    route = Route.load(out)
    assert route.params["surface_classes"] == ["roof"] and 0 < route.shot.sum() < full.shot.sum()
    ev = evaluate(route, scene)
    assert {CLASS_NAMES[k] for k in np.unique(ev.samples.kind)} == {"roof"} and ev.metrics["coverage_pct"] == pytest.approx(100.0)
    triangles = np.vstack([m.triangles for m in scene.meshes])
    taken = route.flown_positions()
    views = sum(images(taken[k], route.heading_deg[k], route.pitch_deg[k], route.camera,
                       ev.samples.points, ev.samples.normals, triangles, route.d_opt, 70.0,
                       offset=scene.epsilon * 4).astype(int) for k in route.shots)
    assert views.min() >= 2


def test_distant_start_behind_a_wall_keeps_the_fine_lattice(thesis_camera):
    """A take-off 150 m away, behind a 60 m wide, 20 m tall wall: the flight goes round it
    safely (independent distance check) and the paths between shots keep the lattice spacing
    of a start next to the building."""
    house = load_scene(MESHES / "gabled_house.obj").targets[0].mesh
    wall = box(100, -5, 0, 102, 55, 20)
    scene = scene_from_meshes([house], [wall])
    gsd = gsd_for(thesis_camera, 7.0)
    near = plan(scene, thesis_camera, gsd=gsd, security=SECURITY)
    far = plan(scene, thesis_camera, gsd=gsd, security=SECURITY, start=[175.0, 25.0, 3.0])
    assert far.metrics["lattice_spacing_m"] == near.metrics["lattice_spacing_m"]
    ev = evaluate(far, scene)
    assert ev.safe and ev.metrics["coverage_pct"] == pytest.approx(100.0)
    assert polyline_min_distance(far.positions, scene.meshes, 0.25) >= SECURITY
    crossing = np.flatnonzero(np.diff(np.sign(far.positions[:, 0] - 101.0)) != 0)
    assert len(crossing) == 2  # out and back over x = 101 ...
    for k in crossing:  # ... round the wall's ends or over its top, not through it
        a, b = far.positions[k], far.positions[k + 1]
        t = (101.0 - a[0]) / (b[0] - a[0])
        y, z = a[1:] + t * (b[1:] - a[1:])
        assert y < -5 - SECURITY or y > 55 + SECURITY or z > 20 + SECURITY
