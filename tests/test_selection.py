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
