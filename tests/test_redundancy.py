"""Dropping the shots a finished plan does not need: hand-worked cases, then a plan."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from coverplan import evaluate, get_camera, plan
from coverplan.shots.redundancy import CheckViews, SharpViews, drop_redundant
from coverplan.world.scene import scene_from_meshes
from tests.helpers import box

# Four shots (candidates 10-13) each imaging the same 6 samples, their rays 0, 10, 20 and
# 30 deg off the normal: any three of them hold a pair inside the [5, 35] deg window.
SHOTS = np.array([10, 11, 12, 13])
N_SAMPLES = 6


def _views(min_views=3, covered=None) -> CheckViews:
    who = np.repeat(SHOTS, N_SAMPLES)
    pt = np.tile(np.arange(N_SAMPLES), len(SHOTS))
    a = np.radians(np.repeat([0.0, 10.0, 20.0, 30.0], N_SAMPLES))
    rays = np.column_stack([np.sin(a), np.zeros_like(a), np.cos(a)])
    covered = np.ones(N_SAMPLES, dtype=bool) if covered is None else covered
    return CheckViews(who, pt, rays, covered, min_views, 5.0, 35.0)


def test_drops_the_latest_shot_the_others_cover_for():
    assert drop_redundant(SHOTS, _views()).tolist() == [10, 11, 12]


def test_keeps_every_shot_a_covered_sample_needs():
    assert drop_redundant(SHOTS, _views(min_views=4)).tolist() == SHOTS.tolist()
    # Samples not covered to begin with hold nothing back: with 5 views asked, none is covered.
    assert drop_redundant(SHOTS, _views(min_views=5, covered=np.zeros(N_SAMPLES, bool))).tolist() == []


def test_keeps_the_only_pair_inside_the_window():
    # Two views asked: 13 goes (10-11-12 hold pairs 10 and 20 deg apart), then 12 (10-11 are
    # 10 deg apart); 11 and 10 each are one of the last two views.
    assert drop_redundant(SHOTS, _views(min_views=2)).tolist() == [10, 11]
    # A 12 deg lower bound: 10 and 11 are too close, so 12 stays and 11 goes instead.
    views = _views(min_views=2)
    views.min_triangulation_deg = 12.0
    assert drop_redundant(SHOTS, views).tolist() == [10, 12]


def test_keeps_the_only_sharp_view():
    # Only shot 13 (candidate row 13) is sharp for sample 0: 12 goes instead of it.
    m = sp.csr_matrix((np.ones(1), ([13], [0])), shape=(14, N_SAMPLES))
    assert drop_redundant(SHOTS, _views(), [SharpViews(m, 1)]).tolist() == [10, 11, 13]
    # Asking for no sharp view leaves it free to go.
    assert drop_redundant(SHOTS, _views(), [SharpViews(m, 0)]).tolist() == [10, 11, 12]


def test_keeps_the_links_in_one_piece_and_every_shot_its_neighbours():
    # Links form the path 10 - 11 - 13 - 12: dropping 13 would cut 12 off.
    links = np.zeros((4, 4), dtype=bool)
    for a, b in ((0, 1), (1, 3), (3, 2)):
        links[a, b] = links[b, a] = True
    out = drop_redundant(SHOTS, _views(), links=links, min_neighbours=1)
    assert out.tolist() == [10, 11, 13]
    # With two neighbours asked, 11 and 13 have them and 10 and 12 do not: 11 and 13 may not
    # lose one, so nothing can go.
    assert drop_redundant(SHOTS, _views(), links=links, min_neighbours=2).tolist() == SHOTS.tolist()


def test_a_pruned_plan_keeps_what_it_claims():
    scene = scene_from_meshes([box(0, 0, 0, 12, 8, 6)])
    route = plan(scene, get_camera("phantom4pro"), gsd=0.004, security=3.0)
    m = route.metrics
    assert m["redundant_shots_dropped"] > 0 and m["shots"] == m["selected_views"]
    ev = evaluate(route, scene, spacing=0.2, seed=7)  # samples the planner never drew
    assert ev.safe and ev.coverage_pct >= m["planned_coverage_pct"] - 0.1
    g = ev.metrics["shot_graph"]
    assert g["components"] == 1 and g["shots_short_of_neighbours"] <= 0.05 * g["shots"], g


def test_braced_links_gain_no_cut_shot():
    # Links form the ring 10 - 11 - 12 - 13 - 10: no shot is a cut. Dropping any one leaves a
    # chain whose middle shot is the only link between its ends, so braced, none may go.
    links = np.zeros((4, 4), dtype=bool)
    for a, b in ((0, 1), (1, 2), (2, 3), (3, 0)):
        links[a, b] = links[b, a] = True
    assert drop_redundant(SHOTS, _views(), links=links, min_neighbours=1).tolist() == [10, 11, 12]
    assert drop_redundant(SHOTS, _views(), links=links, min_neighbours=1, braced=True).tolist() == SHOTS.tolist()


def test_spare_views_keep_a_view_more_than_the_rule():
    # Each sample has four views and three are asked: one can go, but not with one to spare.
    assert drop_redundant(SHOTS, _views(), spare_views=1).tolist() == SHOTS.tolist()
    assert drop_redundant(SHOTS, _views(min_views=2), spare_views=1).tolist() == [10, 11, 12]


def test_random_braced_drops_keep_the_cut_shots_as_they_were():
    from coverplan.shots.link_graph import cut_shots
    rng = np.random.default_rng(3)
    dropped_any = 0
    for _ in range(40):
        n = 12
        links = np.triu(rng.random((n, n)) < 0.3, 1)
        links = links | links.T
        shots = np.arange(100, 100 + n)
        views = CheckViews(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros(0, bool), 3, 5.0,
                           35.0)
        before = set(cut_shots(sp.csr_matrix(links)).tolist())
        out = drop_redundant(shots, views, links=links, min_neighbours=1, braced=True)
        keep = np.isin(shots, out)
        after = np.flatnonzero(keep)[cut_shots(sp.csr_matrix(links[np.ix_(keep, keep)]))]
        assert set(after.tolist()) <= before
        dropped_any += int((~keep).sum())
    assert dropped_any > 0
