"""View selection on hand-made visibility matrices whose answer is known."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from coverplan.shots.selection import coverage_state, select_views


def _ray(azimuth_deg: float) -> np.ndarray:
    a = np.radians(azimuth_deg)
    return np.array([np.cos(a), np.sin(a), 0.0])


def _problem(azimuths_deg):
    """One sample seen by one candidate per azimuth (rays from the sample to the camera)."""
    n = len(azimuths_deg)
    vis = sp.csr_matrix((np.ones(n, bool), (np.arange(n), np.zeros(n, int))), shape=(n, 1))
    vis.sort_indices()
    return vis, np.array([_ray(a) for a in azimuths_deg])


def test_pair_only_two_new_shots_form_is_taken():
    # Three shots already taken, pairwise 60 deg apart (too far to match); the only pair in
    # the 5-35 deg window is two candidates not yet taken, 10 deg apart. Neither gains
    # anything alone, so a one-step greedy stops with the sample uncovered.
    vis, rays = _problem([0.0, 60.0, 120.0, 170.0, 180.0])
    sel = select_views(vis, rays, 3, 5.0, lp_time_limit=0, max_pair_deg=35.0, preset=[0, 1, 2])
    assert {3, 4} <= set(sel.chosen.tolist())
    _, covered = coverage_state(vis, rays, sel.chosen, 3, 5.0, 35.0)
    assert covered.all() and sel.satisfied.all()


def test_uncoverable_sample_adds_nothing():
    # Every pair is wider than 35 deg: no selection covers it, so none is added for it.
    vis, rays = _problem([0.0, 60.0, 120.0, 180.0])
    sel = select_views(vis, rays, 3, 5.0, lp_time_limit=0, max_pair_deg=35.0, preset=[0, 1, 2])
    assert sorted(sel.chosen.tolist()) == [0, 1, 2]
    assert not sel.satisfied.any()


def test_the_cover_brings_the_wanted_views_along():
    # Four candidates 10 deg apart see one sample; three views are asked. Alone the cover takes
    # the first three; with candidate 3 the only wanted (sharp) view it takes that one among
    # its three instead of needing a fourth afterwards.
    vis, rays = _problem([0.0, 10.0, 20.0, 30.0])
    plain = select_views(vis, rays, 3, 5.0, lp_time_limit=0, max_pair_deg=35.0)
    assert sorted(plain.chosen.tolist()) == [0, 1, 2]
    wanted = sp.csr_matrix(([1.0], ([3], [0])), shape=(4, 1))
    joint = select_views(vis, rays, 3, 5.0, lp_time_limit=0, max_pair_deg=35.0, wanted=wanted)
    assert 3 in joint.chosen.tolist() and len(joint.chosen) == 3 and joint.satisfied.all()


def test_every_sample_gets_a_wanted_view_on_random_problems():
    rng = np.random.default_rng(4)
    for _ in range(20):
        n_cand, n_samp = 40, 60
        vis = sp.random(n_cand, n_samp, density=0.25, random_state=rng, format="csr")
        vis.data[:] = 1.0
        vis.sort_indices()
        a = rng.uniform(0, 40, vis.nnz)
        rays = np.array([_ray(x) for x in a])
        wanted = vis.multiply(sp.random(n_cand, n_samp, density=0.3, random_state=rng, format="csr") > 0).tocsr()
        plain = select_views(vis, rays, 3, 5.0, max_pair_deg=35.0)
        joint = select_views(vis, rays, 3, 5.0, max_pair_deg=35.0, wanted=wanted)
        offered = np.asarray(wanted.sum(axis=0)).ravel() > 0
        got = np.asarray(wanted[joint.chosen].sum(axis=0)).ravel()
        assert (got[offered] >= 1).all()
        # the cover's own rule holds as it does without the wanted views
        assert (joint.satisfied | ~plain.satisfied).all()
        assert joint.lp_bound >= plain.lp_bound - 1e-6


def test_an_lp_out_of_time_is_dropped_and_says_so():
    # The LP's time limit is wall time: an LP that reaches it leaves the greedy without its
    # guide, so the shots depend on the machine's speed. The selection must say so (the plan
    # warns on it) and still cover what the plain greedy covers.
    rng = np.random.default_rng(4)
    vis = sp.random(400, 600, density=0.05, random_state=rng, format="csr")
    vis.data[:] = 1.0
    vis.sort_indices()
    rays = np.array([_ray(x) for x in rng.uniform(0, 40, vis.nnz)])
    solved = select_views(vis, rays, 3, 5.0, max_pair_deg=35.0)
    assert not solved.lp_stopped and solved.lp_bound is not None
    out_of_time = select_views(vis, rays, 3, 5.0, max_pair_deg=35.0, lp_time_limit=1e-9)
    assert out_of_time.lp_stopped and out_of_time.lp_bound is None
    greedy = select_views(vis, rays, 3, 5.0, max_pair_deg=35.0, lp_time_limit=0)
    assert not greedy.lp_stopped  # not asked for is not stopped
    assert np.array_equal(out_of_time.satisfied, greedy.satisfied)
    assert np.array_equal(np.sort(out_of_time.chosen), np.sort(greedy.chosen))
