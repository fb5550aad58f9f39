"""The SfM rule: matchable view pairs, linked photos, one connected set (hand-worked cases)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from coverplan import evaluate, get_camera, plan
from coverplan.shots.bracing import bracing_gain
from coverplan.shots.connecting import connect_shots
from coverplan.shots.link_graph import cut_shots, graph_summary
from coverplan.shots.reconstructability import MatchRule, candidate_links, shot_links
from coverplan.shots.sharpness import add_sharp_views, incidence_deg, sharp_targets
from coverplan.shots.visibility import has_pair_between, widest_pair_angle
from coverplan.world.scene import scene_from_meshes
from tests.helpers import box


def _rays(*angles_deg):
    a = np.radians(angles_deg)
    return np.column_stack([np.sin(a), np.zeros_like(a), np.cos(a)])


def test_pair_window_needs_a_pair_inside_it():
    # point 0: rays 0/3 deg (too narrow); point 1: 0/20 (inside); point 2: 0/60 (too wide);
    # point 3: 0/3/60 (no pair in [5, 35], though widest is 60); point 4: one ray.
    rays = np.vstack([_rays(0, 3), _rays(0, 20), _rays(0, 60), _rays(0, 3, 60), _rays(0)])
    pts = np.array([0, 0, 1, 1, 2, 2, 3, 3, 3, 4])
    assert has_pair_between(pts, rays, 5, 5.0, 35.0).tolist() == [False, True, False, False, False]
    # Without an upper bound it is the thesis's rule: the widest pair is wide enough.
    assert has_pair_between(pts, rays, 5, 5.0, None).tolist() == (widest_pair_angle(pts, rays, 5) >= 5).tolist()
    assert has_pair_between(pts, rays, 5, 5.0, None).tolist() == [False, True, True, True, False]


@pytest.mark.parametrize("hi_deg", [35.0, None])
def test_pair_window_on_many_rays_is_the_brute_force_answer(hi_deg):
    """Points with up to 40 rays, shuffled, most within a few degrees of each other: the first
    look at 8 rays a point and the full look after it agree with every pair tried by hand."""
    rng = np.random.default_rng(7)
    n = 300
    counts = rng.integers(1, 41, n)
    pts = rng.permutation(np.repeat(np.arange(n), counts))
    spread = np.where(rng.random(n) < 0.5, 1.2, 30.0)[pts]  # narrow points need a late wide ray
    angles = rng.normal(0.0, 1.0, (len(pts), 2)) * spread[:, None]
    rays = np.column_stack([np.sin(np.radians(angles[:, 0])), np.sin(np.radians(angles[:, 1])), np.ones(len(pts))])
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    expected = np.zeros(n, dtype=bool)
    for p in range(n):
        r = rays[pts == p]
        deg = np.degrees(np.arccos(np.clip(r @ r.T, -1.0, 1.0)))
        expected[p] = ((deg >= 5.0) & (deg <= (hi_deg or 180.0))).any()
    got = has_pair_between(pts, rays, n, 5.0, hi_deg)
    assert np.array_equal(got, expected)
    assert 0.1 < expected.mean() < 0.95
    # the full look mattered: some points have no such pair among their first 8 rays
    first = np.concatenate([np.flatnonzero(pts == p)[:8] for p in range(n)])
    assert (got & ~has_pair_between(pts[first], rays[first], n, 5.0, hi_deg)).any()


def _wall_samples(n=41):
    """Samples on the wall x=0, y in [0, 40], z in [0, 4]."""
    y, z = np.meshgrid(np.linspace(0, 40, n), np.linspace(0, 4, 5))
    return np.column_stack([np.zeros(y.size), y.ravel(), z.ravel()])


def _sees(points, centre, half_width):
    return np.abs(points[:, 1] - centre) <= half_width


def test_links_need_overlap_and_a_narrow_angle():
    pts = _wall_samples()
    # Cameras 10 m from the wall: 0 and 1 two metres apart (same footprint nearly, ~11 deg),
    # 2 far along the wall (no shared surface), 3 at the same spot as 0 seen from a 70 deg angle.
    positions = np.array([[10.0, 10.0, 2.0], [10.0, 12.0, 2.0], [10.0, 35.0, 2.0],
                          [3.4, 10.0 + 9.4, 2.0]])
    vis = sp.csr_matrix(np.array([_sees(pts, 10, 5), _sees(pts, 12, 5), _sees(pts, 35, 5),
                                  _sees(pts, 10, 5)], dtype=float))
    links = shot_links(vis, positions, pts, MatchRule(max_pair_deg=35, min_overlap=0.3))
    assert links[0, 1] and links[1, 0]
    assert not links[0, 2] and not links[1, 2]
    assert not links[0, 3]  # same surface, but 70 deg apart: SfM would not match them
    s = graph_summary(links, MatchRule(min_neighbours=1))
    assert s["components"] == 3 and s["largest_component"] == 2 and s["shots_short_of_neighbours"] == 2


def _corner():
    """Samples on two walls meeting at a corner at the origin (the building at x < 0, y > 0):
    a south wall (normal -y) and an east wall (normal +x), 5 m long and 4 m high."""
    u = np.linspace(0.25, 4.75, 10)
    z = np.linspace(0.25, 3.75, 8)
    uu, zz = (a.ravel() for a in np.meshgrid(u, z))
    south = np.column_stack([-uu, np.zeros_like(uu), zz])
    east = np.column_stack([np.zeros_like(uu), uu, zz])
    points = np.vstack([south, east])
    normals = np.vstack([np.tile([0.0, -1.0, 0.0], (len(south), 1)), np.tile([1.0, 0.0, 0.0], (len(east), 1))])
    return points, normals


def test_a_pair_across_a_corner_links_only_where_both_see_a_face_squarely():
    """Two photos that each see both walls, one squarely and the other at 69 deg: their rays
    meet 29 deg apart at the centroid of the surface both see (inside the building), so the
    centroid test links them; face by face, one of them always sees the wall edge-on, so the
    faces test does not. A third photo beside the first, on the south wall, links by both."""
    points, normals = _corner()
    positions = np.array([[3.0, -6.0, 2.0], [6.0, -3.0, 2.0], [1.0, -7.0, 2.0]])
    vis = sp.csr_matrix(np.ones((3, len(points))))
    centroid = shot_links(vis, positions, points, MatchRule())
    faces = shot_links(vis, positions, points, MatchRule(link_test="faces"), normals=normals)
    assert centroid[0, 1] and not faces[0, 1] and not faces[1, 0]
    assert faces[0, 2] and faces[2, 0] and centroid[0, 2]
    assert (faces == faces.T).all() and not faces.diagonal().any()
    with pytest.raises(ValueError, match="normals"):
        shot_links(vis, positions, points, MatchRule(link_test="faces"))


def _cameras_round_the_corner(rng):
    """Up to 40 cameras outside the corner, each seeing at random 80 % of the samples it faces:
    (points, normals, positions, vis)."""
    points, normals = _corner()
    positions = np.column_stack([rng.uniform(-6, 9, 40), rng.uniform(-9, 6, 40), rng.uniform(0, 4, 40)])
    positions = positions[(positions[:, 0] > 0.5) | (positions[:, 1] < -0.5)]
    facing = np.einsum("ijk,jk->ij", positions[:, None, :] - points[None], normals) > 0
    vis = sp.csr_matrix(facing & (rng.random(facing.shape) < 0.8))
    return points, normals, positions, vis


def _touching(n: int, rows: np.ndarray) -> np.ndarray:
    """(n, n) bool: the pairs with one of ``rows`` at an end."""
    touches = np.zeros((n, n), dtype=bool)
    touches[rows] = touches[:, rows] = True
    return touches


def test_faces_links_of_some_rows_are_the_whole_graphs():
    rng = np.random.default_rng(5)
    points, normals, positions, vis = _cameras_round_the_corner(rng)
    n = len(positions)
    rule = MatchRule(link_test="faces")
    whole = candidate_links(vis, positions, points, rule, normals=normals)
    assert whole.nnz > 10
    for rows in (np.arange(0, n, 3), rng.choice(n, n // 2, replace=False)):
        part = candidate_links(vis, positions, points, rule, rows=rows, normals=normals).toarray()
        assert (part == (whole.toarray() * _touching(n, rows))).all()


def test_samples_links_are_the_count_sample_by_sample(monkeypatch):
    """The "samples" link test equals the independent loop over every pair of views of every
    sample (tests/independent.py), for the whole graph and for some rows, also when its pairs
    are judged in chunks of a few samples."""
    from coverplan.shots import reconstructability
    from tests.independent import per_sample_links
    rng = np.random.default_rng(8)
    points, normals, positions, vis = _cameras_round_the_corner(rng)
    n = len(positions)
    cam, pt = vis.nonzero()
    rule = MatchRule(link_test="samples")
    exact = per_sample_links(positions, cam, pt, points, normals, rule.max_pair_deg, 60.0, rule.min_overlap)
    assert 10 < exact.sum() < n * (n - 1)  # some pairs link, not all
    for chunk in (reconstructability.PAIRS_PER_CHUNK, 50):
        monkeypatch.setattr(reconstructability, "PAIRS_PER_CHUNK", chunk)
        assert (shot_links(vis, positions, points, rule, normals=normals) == exact).all()
        rows = rng.choice(n, n // 3, replace=False)
        part = candidate_links(vis, positions, points, rule, rows=rows, normals=normals).toarray() > 0
        assert (part == (exact & _touching(n, rows))).all()


@pytest.mark.parametrize("mesh", ["gabled_house.obj", "l_prism.obj"])
def test_faces_links_are_links_sample_by_sample(mesh):
    """The planner's face-by-face links, re-checked sample by sample on the evaluator's samples
    by an independent count (tests/independent.py): nearly all of them hold, more of them than
    of the centroid test's links (measured: the gabled house 96 % against 86 %, the L prism 98 %
    against 97 %)."""
    from coverplan import load_scene
    from coverplan.evaluation.photos import photo_poses
    from tests.helpers import MESHES
    from tests.independent import per_sample_links
    scene = load_scene(MESHES / mesh)
    held = {}
    for test in ("centroid", "faces"):
        rule = MatchRule(link_test=test)
        route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0, match=rule)
        assert route.params["link_test"] == test
        ev = evaluate(route, scene)
        assert ev.metrics["shot_graph"]["link_test"] == test
        cam, pt, _ = ev.pairs
        positions = photo_poses(route)[0]
        n = len(positions)
        vis = sp.csr_matrix((np.ones(len(cam)), (cam, pt)), shape=(n, len(ev.samples)))
        planned = shot_links(vis, positions, ev.samples.points, rule, normals=ev.samples.normals)
        exact = per_sample_links(positions, cam, pt, ev.samples.points, ev.samples.normals,
                                 rule.max_pair_deg, 60.0, rule.min_overlap)
        upper = np.triu_indices(n, 1)
        held[test] = (planned & exact)[upper].sum() / max(planned[upper].sum(), 1)
    assert held["faces"] >= 0.93, held
    assert held["faces"] > held["centroid"], held


def test_candidate_links_of_some_rows_are_the_whole_graphs():
    """Links worked out for a subset of cameras (the planner's repair does so for its new
    candidates) are exactly the whole graph's links at those cameras, and agree with the
    dense shot_links."""
    rng = np.random.default_rng(2)
    pts = _wall_samples(81)
    centres = rng.uniform(0, 40, 60)
    positions = np.column_stack([rng.uniform(6, 12, 60), centres + rng.normal(0, 3, 60), rng.uniform(0, 4, 60)])
    vis = sp.csr_matrix(np.array([_sees(pts, c, w) for c, w in zip(centres, rng.uniform(3, 8, 60))], dtype=bool))
    rule = MatchRule(max_pair_deg=35, min_overlap=0.3)
    whole = candidate_links(vis, positions, pts, rule)
    assert (whole.toarray().astype(bool) == shot_links(vis.astype(float), positions, pts, rule)).all()
    assert 100 < whole.nnz < 60 * 59
    for rows in (np.arange(0, 60, 7), np.array([3]), rng.choice(60, 30, replace=False)):
        part = candidate_links(vis, positions, pts, rule, rows=rows).toarray()
        touches = np.zeros((60, 60), dtype=bool)
        touches[rows] = touches[:, rows] = True
        assert (part == (whole.toarray() * touches)).all()


def test_connect_adds_the_bridging_shot_and_nothing_useless():
    pts = _wall_samples()
    centres = [4, 6, 8, 32, 34, 36, 20, 14, 26, 20.5]
    positions = np.array([[10.0, c, 2.0] for c in centres])
    vis = sp.csr_matrix(np.array([_sees(pts, c, 5) for c in centres], dtype=float))
    rule = MatchRule(min_neighbours=2)
    chosen = np.array([0, 1, 2, 3, 4, 5])  # two groups 24 m apart: no shared surface
    assert graph_summary(shot_links(vis[chosen], positions[chosen], pts, rule))["components"] == 2
    out = connect_shots(vis, positions, pts, chosen, rule)
    links = shot_links(vis[out], positions[out], pts, rule)
    summary = graph_summary(links, rule)
    assert summary["components"] == 1 and summary["shots_short_of_neighbours"] == 0
    assert out[:6].tolist() == chosen.tolist()
    assert set(out[6:]) <= {6, 7, 8, 9} and len(out) <= 9  # a chain 14 - 20 - 26 bridges 8 m steps


def test_default_plan_links_every_photo_and_thesis_rule_does_not_have_to():
    scene = scene_from_meshes([box(0, 0, 0, 12, 8, 6)])
    camera = get_camera("phantom4pro")
    route = plan(scene, camera, gsd=0.004, security=3.0)
    assert route.params["rule"] == "sfm" and route.params["min_views"] == 3
    ev = evaluate(route, scene, spacing=0.5)  # finer than the planner's samples
    g = ev.metrics["shot_graph"]
    assert ev.safe and g["components"] == 1, g
    assert g["shots_short_of_neighbours"] <= 0.05 * g["shots"], g
    thesis = plan(scene, camera, gsd=0.004, security=3.0, rule="thesis")
    assert thesis.params["min_views"] == 2 and "max_pair_deg" not in thesis.params
    assert len(thesis.shots) < len(route.shots)


@pytest.mark.parametrize("spacing", [0.25, 0.2])
def test_links_hold_on_the_evaluators_samples(ring_job, spacing):
    """The evaluator, on samples of its own (0.25 m, and 0.2 m), finds every photo in one
    matchable set with 2 neighbours. Judged on the planner's samples alone, this plan was
    four sets (the largest 139 of 181 photos)."""
    scene, route = ring_job
    g = evaluate(route, scene, spacing=spacing).metrics["shot_graph"]
    assert g["components"] == 1 and g["shots_short_of_neighbours"] == 0, g


def test_cut_shots_are_the_articulation_points():
    """Against networkx on random graphs, and by hand: a chain's inner photos, a bow tie's knot."""
    import networkx as nx
    rng = np.random.default_rng(7)
    for _ in range(200):
        n = int(rng.integers(1, 30))
        a = np.triu(rng.random((n, n)) < rng.uniform(0.02, 0.4), 1)
        a = a | a.T
        assert list(cut_shots(sp.csr_matrix(a))) == sorted(nx.articulation_points(nx.from_numpy_array(a.astype(int))))
    chain = sp.diags([np.ones(4), np.ones(4)], [1, -1], shape=(5, 5))
    assert list(cut_shots(chain)) == [1, 2, 3]
    bow = nx.to_scipy_sparse_array(nx.Graph([(0, 1), (1, 2), (2, 0), (2, 3), (3, 4), (4, 2)]))
    assert list(cut_shots(bow)) == [2]


def test_a_candidate_braces_the_cuts_it_spans():
    """On the chain 0-1-2-3-4, a candidate linked to 0 and 2 braces 1; one linked to 1 and 3
    braces 2; one linked to 0 and 4 braces all three; one linked to 2 alone braces none."""
    chain = sp.csr_matrix(sp.diags([np.ones(4), np.ones(4)], [1, -1], shape=(5, 5)))
    to_shots = sp.csr_matrix(np.array([[1, 0, 1, 0, 0], [0, 1, 0, 1, 0], [1, 0, 0, 0, 1], [0, 0, 1, 0, 0]]))
    assert bracing_gain(chain, to_shots, cut_shots(chain)).tolist() == [1, 1, 3, 0]


def test_bracing_gain_counts_the_pieces_each_cut_leaves():
    """On random graphs (chains with chords, some in several pieces), against the definition:
    remove the cut, find the pieces, count the candidates that link to two of them."""
    from scipy.sparse.csgraph import connected_components
    rng = np.random.default_rng(11)
    for _ in range(150):
        k, m = int(rng.integers(3, 60)), int(rng.integers(1, 120))
        links = np.zeros((k, k), dtype=bool)
        links[np.arange(k - 1), np.arange(1, k)] = rng.random(k - 1) < 0.9
        links |= rng.random((k, k)) < rng.uniform(0, 0.08)
        links |= links.T
        np.fill_diagonal(links, False)
        to_shots = rng.random((m, k)) < rng.uniform(0.01, 0.2)
        cuts = cut_shots(links)
        want = np.zeros(m, dtype=np.int64)
        for a in cuts:
            keep = np.flatnonzero(np.arange(k) != a)
            _n, piece = connected_components(sp.csr_matrix(links[np.ix_(keep, keep)]), directed=False)
            pieces_reached = [len(set(piece[np.flatnonzero(to_shots[c, keep])])) for c in range(m)]
            want += np.array(pieces_reached) >= 2
        assert bracing_gain(sp.csr_matrix(links), sp.csr_matrix(to_shots), cuts).tolist() == want.tolist()


def test_braced_links_leave_no_photo_the_set_hangs_on(house_job):
    """The gabled house's photos linked only into one piece were a chain: 16 of 38 photos
    were each the only link between two groups (one of three field draws split the model
    there). Braced, on the evaluator's own samples, fewer such photos remain, and none on the
    ring prism."""
    scene, route = house_job
    braced = evaluate(route, scene).metrics["shot_graph"]
    one_piece = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0, match=MatchRule(braced=False))
    loose = evaluate(one_piece, scene).metrics["shot_graph"]
    assert route.params["braced_links"] and not one_piece.params["braced_links"]
    assert braced["components"] == 1 and loose["components"] == 1
    assert braced["cut_shots"] <= loose["cut_shots"] // 2, (braced, loose)
    assert len(route.shots) <= 1.3 * len(one_piece.shots)


def test_braced_ring_has_no_cut_photo(ring_job):
    scene, route = ring_job
    g = evaluate(route, scene).metrics["shot_graph"]
    assert g["components"] == 1 and g["cut_shots"] == 0, g


def test_bad_rule_settings_are_one_line_errors(capsys, tmp_path):
    from coverplan.cli import main
    from tests.helpers import MESHES
    base = ["plan", str(MESHES / "square_prism.obj"), "--camera", "thesis80", "--gsd", "0.005",
            "--security", "3", "-o", str(tmp_path / "r.json")]
    for extra, text in ((["--max-pair-deg", "120"], "(--max-pair-deg) must be in (0, 90)"),
                        (["--min-overlap", "0"], "(--min-overlap) must be in (0, 1]"),
                        (["--rule", "thesis", "--max-pair-deg", "30"], "--max-pair-deg belongs to --rule sfm"),
                        (["--sharp-views", "-1"], "(--sharp-views) must be a whole number >= 0"),
                        (["--min-cut", "-1"], "(--min-cut) must be a whole number >= 0"),
                        (["--rule", "thesis", "--min-cut", "3"], "--min-cut belongs to --rule sfm"),
                        (["--rule", "thesis", "--sharp-views", "2"], "--sharp-views belongs to --rule sfm"),
                        (["--rule", "thesis", "--link-test", "faces"], "--link-test belongs to --rule sfm"),
                        (["--min-triangulation-deg", "40"], "must be below the widest matchable pair")):
        assert main(base + extra) == 2
        err = capsys.readouterr().err.strip()
        assert text in err and len(err.splitlines()) == 1, err


@pytest.mark.parametrize("rule", ["sfm", "thesis"])
def test_route_file_keeps_the_rule_and_evaluate_applies_it(tmp_path, rule):
    from coverplan import Route
    scene = scene_from_meshes([box(0, 0, 0, 10, 10, 5)])
    route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0, rule=rule)
    path = route.save(tmp_path / "r.json")
    back = Route.load(path)
    assert back.params["rule"] == rule
    assert back.params.get("max_pair_deg") == (35.0 if rule == "sfm" else None)
    assert evaluate(back, scene).coverage_pct == pytest.approx(evaluate(route, scene).coverage_pct)


def test_incidence_is_the_angle_between_normal_and_ray():
    points, normals = np.zeros((3, 3)), np.tile([0.0, 0.0, 1.0], (3, 1))
    cameras = np.array([[0.0, 0.0, 5.0], [5.0, 0.0, 5.0], [4.0, 0.0, 0.0]])
    assert incidence_deg(np.arange(3), np.arange(3), cameras, points, normals) == pytest.approx([0, 45, 90])


def test_sharp_views_take_the_square_view_or_the_best_there_is():
    # Sample 0: the chosen camera 0 sees it at 60 deg, camera 1 at 10 deg. Sample 1: nothing
    # reaches 35 deg; camera 2 at 48 deg is within 5 deg of its best (45, camera 3, which
    # also sees sample 0 at 20 deg); camera 4 sees only sample 1 at 70 deg.
    cam = np.array([0, 1, 0, 2, 3, 3, 4])
    pt = np.array([0, 0, 1, 1, 1, 0, 1])
    inc = np.array([60.0, 10.0, 62.0, 48.0, 45.0, 20.0, 70.0])
    targets = sharp_targets(pt, inc, 2)
    assert targets == pytest.approx([35.0, 50.0])
    area = np.array([2.0, 2.0])
    chosen = add_sharp_views(cam, pt, inc, 5, area, np.array([0]))
    assert chosen.tolist() == [0, 3]  # camera 3 serves both samples: one shot, not two
    # Nothing is added for less surface than min_gain_m2, and nothing twice.
    assert add_sharp_views(cam, pt, inc, 5, area, np.array([0]), min_gain_m2=5.0).tolist() == [0]
    assert add_sharp_views(cam, pt, inc, 5, area, np.array([0, 3])).tolist() == [0, 3]
    # Two sharp views asked: sample 0 gets camera 1 too, sample 1 camera 2.
    assert sorted(add_sharp_views(cam, pt, inc, 5, area, np.array([0]), views=2).tolist()) == [0, 1, 2, 3]


def _best_incidence(route, mesh, points, normals):
    """Independently of the planner: per point, the smallest incidence of a shot that images it."""
    from tests.independent import images
    best = np.full(len(points), np.inf)
    taken = route.flown_positions()  # where the photos are taken
    for k in route.shots:
        pos = taken[k]
        seen = images(pos, route.heading_deg[k], route.pitch_deg[k], route.camera, points, normals,
                      mesh.triangles, route.d_opt, 70.0)
        v = pos - points[seen]
        inc = np.degrees(np.arccos(np.clip((v * normals[seen]).sum(1) / np.linalg.norm(v, axis=1), -1, 1)))
        best[seen] = np.minimum(best[seen], inc)
    return best


def test_default_plan_sees_every_face_squarely_where_it_can():
    """Gabled house: every wall and roof point can be seen within 35 deg of its normal, and the
    default plan does so, checked on points and ray casts of this test's own."""
    import trimesh

    from coverplan import load_scene
    from tests.helpers import MESHES
    scene = load_scene(MESHES / "gabled_house.obj")
    mesh = scene.targets[0].mesh
    points, face = trimesh.sample.sample_surface_even(mesh, 4000, seed=11)
    normals = mesh.face_normals[face]
    up = normals[:, 2] > -0.5  # the floor rests on the ground
    points, normals = points[up], normals[up]
    camera = get_camera("phantom4pro")
    # the shots' choice is what is judged: photos taken where they are planned (no turns cut)
    sharp = plan(scene, camera, gsd=0.004, security=3.0, fly="stop")
    assert sharp.params["sharp_views"] == 1  # asked of the cover itself, so few or no shots are added for it
    best = _best_incidence(sharp, mesh, points, normals)
    imaged = np.isfinite(best)
    assert imaged.mean() > 0.99
    assert (best[imaged] <= 35.5).mean() >= 0.995, np.sort(best[imaged])[-10:]
    # The rule's own effect: edge views, which look at the eaves from above, see a few more
    # roof points squarely (0.81 of them with edge views and without the rule).
    slanted = plan(scene, camera, gsd=0.004, security=3.0, match=MatchRule(sharp_views=0, framed_views=0), fly="stop",
                   edge_views=False)
    best0 = _best_incidence(slanted, mesh, points, normals)
    roof = normals[:, 2] > 0.5
    assert (best0[roof] <= 35.5).mean() < 0.8  # without the rule, much of the roof is seen at a slant
    ev = evaluate(sharp, scene)
    assert ev.metrics["sharp_view_pct"] >= 99.5 and ev.metrics["best_incidence_deg"]["max"] <= 36.0


def test_overhang_undersides_are_seen_as_squarely_as_the_gimbal_allows(monkeypatch):
    """A 6 m tower carrying a 12 m block from 9 m up: the 3 m deep underside can only be seen
    from below, the gimbal tilting up 30 deg at most. Cameras placed for that steepest view
    (candidates.under_overhangs) bring its best incidence down, checked with this test's own
    points and ray casts; without them the plan sees it at a slant."""
    import trimesh

    from coverplan.planning import problem as problem_stage
    from coverplan.shots.candidates import Candidates
    from coverplan.shots.repair import GapCloser
    target = trimesh.boolean.union([box(0, 0, 0, 6, 6, 9.5), box(-3, -3, 9, 9, 9, 13)], engine="manifold")
    scene = scene_from_meshes([target])
    mesh = scene.targets[0].mesh
    points, face = trimesh.sample.sample_surface_even(mesh, 6000, seed=5)
    normals = mesh.face_normals[face]
    under = (normals[:, 2] < -0.5) & (points[:, 2] > 8)
    points, normals = points[under], normals[under]
    camera = get_camera("phantom4pro")
    route = plan(scene, camera, gsd=0.004, security=3.0)
    assert evaluate(route, scene).metrics["safe"]
    best = _best_incidence(route, mesh, points, normals)
    assert np.isfinite(best).all()
    # Steepest view: pitch 30 deg plus 90 % of half the vertical field of view, 90 - 53.9 = 36 deg.
    assert np.percentile(best, 90) <= 43.0 and np.median(best) <= 39.0, np.percentile(best, [50, 90])
    # The sharp views asked on the 0.25 m check samples too (GapCloser.sharpen): without them
    # the strips between the planner's samples keep their slanted views.
    monkeypatch.setattr(GapCloser, "sharpen", lambda self, chosen, views, kinds=None: chosen)
    coarse = _best_incidence(plan(scene, camera, gsd=0.004, security=3.0), mesh, points, normals)
    assert np.percentile(coarse, 90) > 44.0, np.percentile(coarse, [50, 90])
    monkeypatch.setattr(problem_stage, "under_overhangs", lambda *a, **k: Candidates.empty())
    slanted = _best_incidence(plan(scene, camera, gsd=0.004, security=3.0), mesh, points, normals)
    assert np.percentile(slanted, 90) > 45.0 and np.median(slanted) > 40.0, np.percentile(slanted, [50, 90])


def test_cli_link_test_is_kept_in_the_route_and_applied_by_evaluate(tmp_path):
    from coverplan import Route
    from coverplan.cli import main
    from tests.helpers import MESHES
    out = tmp_path / "r.json"
    assert main(["plan", str(MESHES / "square_prism.obj"), "--camera", "phantom4pro", "--gsd", "0.004",
                 "--security", "3", "--link-test", "faces", "-o", str(out), "-q"]) == 0
    route = Route.load(out)
    assert route.params["link_test"] == "faces"
    from coverplan import load_scene
    scene = load_scene(MESHES / "square_prism.obj")
    # The evaluator judges the links by the route's own test. (Its verdict is not asserted: on
    # this prism it finds the faces plan in two pieces, docs/reconstruction.md.)
    assert evaluate(route, scene).metrics["shot_graph"]["link_test"] == "faces"


def test_pieces_are_joined_through_the_chains_already_added():
    """Three pieces of two shots (A: 0-1, B: 2-3, C: 4-5) and candidates: p joins A and B,
    r - s joins A and C, z joins B and C. Chained one by one from A along shortest chains,
    B comes through p and C through r and s (3 shots; through p, B and z it is one hop
    longer). Joining the nearest piece first and then searching from the grown piece takes
    p, then z: 2 shots. The lean selection (the "samples" link test) keeps the fewer."""
    n = 10
    p, r, s, z = 6, 7, 8, 9
    edges = [(0, 1), (2, 3), (4, 5), (0, p), (p, 2), (1, r), (r, s), (s, 4), (3, z), (z, 5)]
    rows, cols = zip(*edges)
    links = sp.coo_matrix((np.ones(len(edges)), (rows, cols)), shape=(n, n))
    links = (links + links.T).tocsr()
    start = np.array([0, 1, 2, 3, 4, 5])
    lean = connect_shots(None, None, None, start, MatchRule(min_neighbours=1, link_test="samples"), links=links)
    assert sorted(lean.tolist()) == [0, 1, 2, 3, 4, 5, p, z]
    # the other link tests keep the classic chains (planning.selecting.lean)
    classic = connect_shots(None, None, None, start, MatchRule(min_neighbours=1), links=links)
    assert sorted(classic.tolist()) == [0, 1, 2, 3, 4, 5, p, r, s]


def test_lean_plan_under_the_samples_link_test_keeps_its_claims():
    """Gabled house, ``--link-test samples`` (the lean selection, planning.selecting.lean): fewer photos than
    the default plan, and the evaluator, on samples of its own, finds the coverage, the sharp
    views, every photo's two neighbours and no photo the links hang on, judged sample by sample."""
    from coverplan import load_scene
    from tests.helpers import MESHES
    scene = load_scene(MESHES / "gabled_house.obj")
    camera = get_camera("phantom4pro")
    # Both without edge views: the lean trim may not drop them, and with them it ended at 58
    # photos against the default's 52.
    default = plan(scene, camera, gsd=0.004, security=3.0, edge_views=False)
    lean = plan(scene, camera, gsd=0.004, security=3.0, match=MatchRule(link_test="samples"), edge_views=False)
    assert default.metrics["trimmed_shots"] == 0 and lean.params["link_test"] == "samples"
    assert any(n.startswith("WARNING link test samples") for n in lean.extra["notes"])
    assert not any(n.startswith("WARNING link test") for n in default.extra["notes"])
    assert len(lean.shots) < 0.9 * len(default.shots)
    ev = evaluate(lean, scene, spacing=0.2, seed=5)
    assert ev.safe and ev.coverage_pct >= 99.9 and ev.metrics["sharp_view_pct"] >= 99.5
    g = ev.metrics["shot_graph"]
    assert g["link_test"] == "samples" and g["shots_short_of_neighbours"] == 0 and g["cut_shots"] == 0, g


def test_edge_views_look_along_the_bisector_of_every_turn():
    """A 20 x 10 x 8 m box: the surface turns at its four vertical corners and four eaves.
    Every edge view stands 8 m from the box with its nearest point on an edge (distance and
    nearest point worked out here from the box's bounds), looks straight at that point, and
    sees both faces there at 45 deg; the corners and the eaves all get views, the flat faces none."""
    from coverplan.shots.edge_views import EDGE, edge_views
    from coverplan.shots.limits import scene_limits
    from coverplan.shots.surface import sample_surface

    lo, hi = np.array([0.0, 0.0, 0.0]), np.array([20.0, 10.0, 8.0])
    scene = scene_from_meshes([box(*lo, *hi)], [])
    camera = get_camera("phantom4pro")
    limits = scene_limits(scene, security=3.0, d_opt=12.0, max_incidence_deg=70.0, min_altitude=3.0,
                          pitch_range_deg=(-90.0, 30.0), vfov_deg=camera.vfov_deg)
    views = edge_views(sample_surface(scene, 1.0), limits, camera, 8.0)
    assert len(views) > 0 and (views.source == EDGE).all()
    nearest = np.clip(views.positions, lo, hi)
    assert np.allclose(np.linalg.norm(views.positions - nearest, axis=1), 8.0, atol=0.05)
    on_bound = np.isclose(nearest, lo, atol=1e-6) | np.isclose(nearest, hi, atol=1e-6)
    assert (on_bound.sum(axis=1) >= 2).all()  # on an edge, not inside a face
    look = views.view_dirs
    towards = (nearest - views.positions) / 8.0
    assert np.allclose(look, towards, atol=0.02)
    # The two faces at the edge: the bounds the nearest point lies on, each with its outward normal.
    for k in range(len(views)):
        normals = [sign * np.eye(3)[axis] for axis in range(3) for sign, bound in ((-1, lo), (1, hi))
                   if np.isclose(nearest[k, axis], bound[axis], atol=1e-6) and not (sign == -1 and axis == 2)]
        incidence = [np.degrees(np.arccos(-look[k] @ n)) for n in normals]
        assert np.allclose(incidence, 45.0, atol=1.5), incidence
    vertical = np.abs(look[:, 2]) < 0.02
    eave = np.isclose(look[:, 2], -np.sqrt(0.5), atol=0.02)
    assert (vertical | eave).all()
    corners = {(round(x), round(y)) for x, y in nearest[vertical, :2]}
    assert corners == {(0, 0), (20, 0), (0, 10), (20, 10)}
    sides = {tuple(np.round(-look[k, :2] / np.linalg.norm(look[k, :2])).astype(int)) for k in np.flatnonzero(eave)}
    assert sides == {(1, 0), (-1, 0), (0, 1), (0, -1)}


def test_edge_views_join_every_wall_to_the_roof():
    """A 20 x 12 x 8 m box: planned with edge views, each of its four eaves is seen, wall and roof
    alike within 50 deg of their normals, by a photo of the plan (this test's own points, frames
    and ray casts); without them no photo does so at any eave (the candidates look square at
    one face or 30 deg off it). The plan stays safe by an independent distance check and takes
    at most a quarter more photos."""
    from coverplan.cli.summary import plan_summary
    from tests.independent import images, polyline_min_distance
    mesh = box(0, 0, 0, 20, 12, 8)
    scene = scene_from_meshes([mesh])
    camera = get_camera("phantom4pro")

    def bridging(route):
        """Per eave: the photos that see both the wall below it and the roof behind it."""
        counts = []
        for axis, side in ((0, 0.0), (0, 20.0), (1, 0.0), (1, 12.0)):
            outward = np.eye(3)[axis] * (1 if side > 0 else -1)
            wall = np.zeros((9, 3))
            wall[:, axis], wall[:, 1 - axis], wall[:, 2] = side, np.linspace(2.0, (12.0 if axis == 0 else 20.0) - 2.0, 9), 7.5
            roof = wall - 0.5 * outward
            roof[:, 2] = 8.0
            sees = [images(route.positions[k], route.heading_deg[k], route.pitch_deg[k], camera, pts,
                           np.tile(n, (9, 1)), mesh.triangles, route.d_opt, 50.0).any()
                    for k in route.shots for pts, n in ((wall, outward), (roof, (0.0, 0.0, 1.0)))]
            counts.append(int(np.logical_and(sees[0::2], sees[1::2]).sum()))
        return counts

    route = plan(scene, camera, gsd=0.004, security=3.0)  # the default
    assert route.params["edge_views"] is True
    assert polyline_min_distance(route.positions, [mesh], step=0.25) >= 3.0 - 1e-6
    assert min(bridging(route)) >= 1, bridging(route)
    without = plan(scene, camera, gsd=0.004, security=3.0, edge_views=False)
    assert max(bridging(without)) == 0, bridging(without)
    assert len(route.shots) <= 1.25 * len(without.shots), (len(route.shots), len(without.shots))
    # The summary says how many photos are edge views, and names none without them.
    assert route.metrics["edge_view_shots"] >= 4 and without.metrics["edge_view_shots"] == 0
    line = next(row for row in plan_summary(route, verbose=True).splitlines() if row.startswith("edge views"))
    assert line.split()[2:6] == [str(route.metrics["edge_view_shots"]), "of", "the", "shots"], line
    assert "edge views" not in plan_summary(without, verbose=True)


def test_photos_already_taken_stand_in_for_the_edge_views_they_repeat():
    """The box's required edge views: all of them again when photos already taken look the
    other way from the same places, none when the photos taken are those views moved 1 m
    and turned 10 deg; the thesis's rule leaves them out unless asked, the sfm rule takes them."""
    from coverplan.planning.settings import PlanSettings
    from coverplan.shots.candidates import Candidates
    from coverplan.shots.edge_views import edge_views, required_edge_views
    from coverplan.shots.limits import scene_limits
    from coverplan.shots.surface import sample_surface

    scene = scene_from_meshes([box(0.0, 0.0, 0.0, 20.0, 10.0, 8.0)], [])
    camera = get_camera("phantom4pro")
    limits = scene_limits(scene, security=3.0, d_opt=12.0, max_incidence_deg=70.0, min_altitude=3.0,
                          pitch_range_deg=(-90.0, 30.0), vfov_deg=camera.vfov_deg)
    views = edge_views(sample_surface(scene, 1.0), limits, camera, 8.0)
    seen = np.full(len(views), 100)
    required = required_edge_views(views, camera, 8.0, seen)
    assert len(required) >= 8  # four corners, four eaves
    kept = views.subset(required)
    away = Candidates.looking(kept.positions, -kept.view_dirs, limits, source=0)
    assert np.array_equal(required_edge_views(views, camera, 8.0, seen, taken=away), required)
    turn = np.radians(10.0)
    rot = np.array([[np.cos(turn), -np.sin(turn), 0.0], [np.sin(turn), np.cos(turn), 0.0], [0.0, 0.0, 1.0]])
    alike = Candidates.looking(kept.positions + [0.0, 0.0, 1.0], kept.view_dirs @ rot.T, limits, source=0)
    assert len(required_edge_views(views, camera, 8.0, seen, taken=alike)) == 0
    assert PlanSettings(gsd=0.004, security=3.0).edge_views is True
    assert PlanSettings(gsd=0.004, security=3.0, rule="thesis").edge_views is False
    assert PlanSettings(gsd=0.004, security=3.0, rule="thesis", edge_views=True).edge_views is True
