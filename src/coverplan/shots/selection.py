"""View selection: few shots such that every sample gets ``min_views`` views, two of them at
least ``min_triangulation_deg`` apart (the multi-cover problem with a triangulation rule).

1. The LP relaxation (HiGHS interior point): min sum x, each coverable sample's views summing
   to >= min_views, 0 <= x <= 1. Its optimum bounds any plan from below; its solution guides:
2. greedy with lazy gains, seeded with the candidates the LP almost takes (x >= 0.7), each
   gain scaled by 1 + x. The gain of a candidate is, summed over the samples it images, one
   per view still missing plus one when it forms the first wide-enough pair;
3. a pass that drops shots the others make redundant, least LP-favoured first.

On the thesis prism the LP guidance takes the greedy result from 1.33x to 1.16x the bound.
"""

from __future__ import annotations

import heapq
import itertools
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from coverplan.shots.redundancy import coverage_state, prune_redundant
from coverplan.shots.visibility import has_pair_between

_STORED = 6  # view rays remembered per sample for the pair test
_SEED = 0.7  # LP values from which a candidate is taken before the greedy starts


# The view-selection LP's default time. Past it the shots are chosen greedily without the LP,
# which makes the plan depend on the machine's speed: the courtyard at 1.5 mm/px (8,698
# candidates) needs 8 s on a loaded 2-core machine, so 20 s, the earlier default, was reached
# on slower or busier ones and gave other shots.
LP_TIME_LIMIT_S = 120.0


@dataclass
class Selection:
    """The shots a covering selection picked and what they give each sample.

    Parameters
    ----------
    chosen : (k,) int
        Candidate indices, in the order picked.
    views : (n,) int
        Views per sample.
    satisfied : (n,) bool
        Samples with enough views and a pair in the angle window.
    lp_bound : float, optional
        The LP relaxation's optimum.
    lp_stopped : bool
        The LP reached its time limit.
    """
    chosen: np.ndarray  # candidate indices, in the order picked
    views: np.ndarray  # per sample
    satisfied: np.ndarray  # per sample: enough views and a wide pair
    lp_bound: float | None = None  # optimum of the LP relaxation (None if not solved)
    lp_stopped: bool = False  # the LP reached its time limit: the greedy went without its guide


def select_views(vis: sp.csr_matrix, rays: np.ndarray, min_views: int, min_triangulation_deg: float,
                 lp_time_limit: float = LP_TIME_LIMIT_S, progress=None, max_pair_deg: float | None = None,
                 preset=None, wanted: sp.csr_matrix | None = None) -> Selection:
    """Pick candidates (rows of ``vis``) covering the samples (columns).

    ``rays`` holds, in the order of ``vis.data``, the unit vector from sample to camera.
    ``lp_time_limit`` <= 0 skips the LP (plain greedy); an LP that reaches it is dropped too
    (``Selection.lp_stopped``), so the shots then depend on the machine's speed. With
    ``max_pair_deg`` the pair that covers a sample must also be at most that wide (views SfM
    can match), not only wide enough.
    ``preset`` candidates are taken first and kept (the result starts with them).
    ``wanted`` (candidates x samples, 1 where the view is of a kind a sample wants, such as a
    sharp view): every sample some candidate offers one to gets one, asked of the LP and counted
    in the greedy's gains alongside the views (a candidate's gain grows by the samples it gives
    their first wanted view), and kept by the pruning.

    Parameters
    ----------
    vis : scipy.sparse.csr_matrix
        Candidates by samples.
    rays : (m, 3) float
        Unit rays in ``vis.data``'s order.
    min_views : int
        Views a sample needs.
    min_triangulation_deg : float
        The least angle of a triangulating pair.
    lp_time_limit : float
        Seconds.
    progress : Progress, optional
        Reports the stage.
    max_pair_deg : float, optional
        The widest angle of a matching pair.
    preset : (j,) int, optional
        Candidates taken first.
    wanted : scipy.sparse.csr_matrix, optional
        Candidates by samples, views of a kind a sample wants.

    Returns
    -------
    Selection
        The shots.
    """
    vis = vis.tocsr()
    vis.sort_indices()
    n_cand, n_samp = vis.shape
    coverable = np.flatnonzero(np.bincount(vis.indices, minlength=n_samp) >= min_views)
    bound, x, stopped = (None, np.zeros(n_cand), False)
    if wanted is not None:
        wanted = sp.csr_matrix(wanted)
        w_need = (np.asarray(wanted.sum(axis=0)).ravel() > 0).astype(np.int64)
        w_have = np.zeros(n_samp, dtype=np.int64)
    if lp_time_limit > 0 and len(coverable):
        bound, x_lp, stopped = lp_relaxation(vis, coverable, min_views, lp_time_limit, wanted=wanted)
        if x_lp is not None:
            x = x_lp
    indptr, indices = vis.indptr, vis.indices
    cos_tri = np.cos(np.radians(min_triangulation_deg))
    cos_match = -1.0 if max_pair_deg is None else np.cos(np.radians(max_pair_deg))

    def in_window(dots):
        return (dots <= cos_tri) & (dots >= cos_match)  # NaN compares False
    count = np.zeros(n_samp, dtype=np.int64)
    paired = np.zeros(n_samp, dtype=bool)
    stored = np.full((n_samp, _STORED, 3), np.nan)

    def opens_pair(s, r) -> np.ndarray:
        open_pair = ~paired[s] & (count[s] >= 1)
        pairs = np.zeros(len(s), dtype=bool)
        if open_pair.any():
            dots = np.einsum("nkd,nd->nk", stored[s[open_pair]], r[open_pair])
            pairs[open_pair] = in_window(dots).any(axis=1)
        return pairs

    def gain(j: int) -> float:  # opens_pair inlined: the lazy greedy calls this thousands of times
        lo, hi = indptr[j], indptr[j + 1]
        if lo == hi:
            return 0.0
        s = indices[lo:hi]
        seen = count[s]
        g = np.count_nonzero(seen < min_views)
        open_pair = (seen >= 1) & ~paired[s]
        if open_pair.any():
            dots = np.einsum("nkd,nd->nk", stored[s[open_pair]], rays[lo:hi][open_pair])
            g += np.count_nonzero(in_window(dots).any(axis=1))
        if wanted is not None:
            w = wanted.indices[wanted.indptr[j]:wanted.indptr[j + 1]]
            g += np.count_nonzero(w_have[w] < w_need[w])
        return float(g * (1.0 + x[j]))

    def all_gains(candidates: np.ndarray) -> np.ndarray:
        """gain() of many candidates at once (sparse products instead of a Python loop)."""
        sub = vis[candidates]
        rows = np.repeat(np.arange(len(candidates)), np.diff(sub.indptr))
        entries = np.concatenate([np.arange(indptr[j], indptr[j + 1]) for j in candidates]) \
            if len(candidates) else np.zeros(0, np.int64)
        s = indices[entries]
        value = (count[s] < min_views).astype(float)
        open_pair = ~paired[s] & (count[s] >= 1)
        if open_pair.any():
            for lo in range(0, int(open_pair.sum()), 500_000):
                k = np.flatnonzero(open_pair)[lo:lo + 500_000]
                dots = np.einsum("nkd,nd->nk", stored[s[k]], rays[entries[k]])
                value[k] += in_window(dots).any(axis=1)
        total = np.bincount(rows, weights=value, minlength=len(candidates))
        if wanted is not None:
            total = total + wanted[candidates] @ (w_have < w_need).astype(float)
        return total * (1.0 + x[candidates])

    def take(j: int) -> None:
        s = indices[indptr[j]:indptr[j + 1]]
        r = rays[indptr[j]:indptr[j + 1]]
        paired[s[opens_pair(s, r)]] = True
        slot = count[s]
        room = slot < _STORED
        stored[s[room], slot[room]] = r[room]
        count[s] += 1
        if wanted is not None:
            w_have[wanted.indices[wanted.indptr[j]:wanted.indptr[j + 1]]] += 1

    chosen: list[int] = []
    taken = np.zeros(n_cand, dtype=bool)
    fixed = [] if preset is None else [int(j) for j in preset]
    for j in fixed:
        take(j)
        taken[j] = True
        chosen.append(j)
    # The LP's picks, strongest first; it knows nothing of a preset, so after one its picks only
    # weigh the greedy gains.
    seeds = np.flatnonzero((x >= _SEED) & ~taken) if preset is None else np.zeros(0, dtype=np.int64)
    for j in seeds[np.argsort(-x[seeds], kind="stable")]:
        take(j)
        taken[j] = True
        chosen.append(int(j))
    def fresh_heap() -> list:
        free = np.flatnonzero(~taken)
        g = all_gains(free)
        return [(-float(v), int(j)) for v, j in zip(g, free) if v > 0]

    heap = fresh_heap()
    heapq.heapify(heap)
    while True:
        if not heap:
            # Stored gains can be stale upwards too (a new view can open a pair), so look at
            # every candidate once more before stopping.
            heap = fresh_heap()
            if not heap:
                break
            heapq.heapify(heap)
        _neg, j = heapq.heappop(heap)
        if taken[j]:
            continue
        g = gain(j)
        if g <= 0:
            continue
        if heap and -heap[0][0] > g:
            heapq.heappush(heap, (-g, j))
            continue
        take(j)
        taken[j] = True
        chosen.append(int(j))
        if progress is not None:
            progress(1)
    chosen += complete_pairs(vis, rays, np.array(chosen, dtype=np.int64), min_views, min_triangulation_deg, max_pair_deg)
    chosen_arr = prune_redundant(vis, rays, np.array(chosen, dtype=np.int64), min_views, min_triangulation_deg,
                                 max_pair_deg, fixed=len(fixed), wanted=wanted)
    views, satisfied = coverage_state(vis, rays, chosen_arr, min_views, min_triangulation_deg, max_pair_deg)
    return Selection(chosen_arr, views, satisfied, bound, stopped)


def complete_pairs(vis: sp.csr_matrix, rays: np.ndarray, chosen, min_views: int, min_triangulation_deg: float,
                   max_pair_deg: float | None = None) -> list[int]:
    """Candidates to add so that every coverable sample is covered, for the samples whose
    greedy gains cannot see it: when a sample's only pairs in the angle window are two
    candidates not yet taken, neither alone gains anything and the greedy stops short.

    Per such sample (there are few: 13 of 4,200 check samples in a wall seen only between
    obstacles) the pair in the window that needs the fewest new shots, then views to make
    up ``min_views``.

    Parameters
    ----------
    vis : scipy.sparse.csr_matrix
        Candidates by samples.
    rays : (m, 3) float
        Unit rays in ``vis.data``'s order.
    chosen : (k,) int
        Chosen candidates.
    min_views : int
        Views a sample needs.
    min_triangulation_deg : float
        The least angle of a triangulating pair.
    max_pair_deg : float, optional
        The widest angle of a matching pair.

    Returns
    -------
    list of int
        Candidates to add.
    """
    n_cand, n_samp = vis.shape
    _, satisfied = coverage_state(vis, rays, chosen, min_views, min_triangulation_deg, max_pair_deg)
    open_ = np.flatnonzero(~satisfied & (np.bincount(vis.indices, minlength=n_samp) >= min_views))
    if len(open_) == 0:
        return []
    keep = np.isin(vis.indices, open_)  # every entry of vis, for the open samples only
    cand = np.repeat(np.arange(n_cand), np.diff(vis.indptr))[keep]
    samp, ray = vis.indices[keep], rays[keep]
    todo = np.flatnonzero(has_pair_between(samp, ray, n_samp, min_triangulation_deg, max_pair_deg))
    if len(todo) == 0:
        return []
    keep = np.isin(samp, todo)
    order = np.argsort(samp[keep], kind="stable")
    cand, samp, ray = cand[keep][order], samp[keep][order], ray[keep][order]
    bounds = np.searchsorted(samp, np.append(todo, n_samp))
    taken = np.zeros(n_cand, dtype=bool)
    taken[chosen] = True
    c_lo = np.cos(np.radians(min_triangulation_deg))
    c_hi = -1.0 if max_pair_deg is None else np.cos(np.radians(max_pair_deg))
    added: list[int] = []
    for lo, hi in itertools.pairwise(bounds):  # a few samples, each a small pair matrix
        c, r = cand[lo:hi], ray[lo:hi]
        cos = r @ r.T
        ok = (cos <= c_lo + 1e-12) & (cos >= c_hi - 1e-12)
        new = (~taken[c]).astype(int)
        cost = np.where(ok, new[:, None] + new[None, :], 99)
        a, b = np.unravel_index(np.argmin(cost), cost.shape)
        if cost[a, b] > 0:
            for k in (a, b):
                if not taken[c[k]]:
                    taken[c[k]] = True
                    added.append(int(c[k]))
        short = min_views - int(taken[c].sum())
        if short > 0:
            extra = c[~taken[c]][:short]
            taken[extra] = True
            added.extend(int(j) for j in extra)
    return added


def lp_relaxation(vis: sp.csr_matrix, samples, min_views: int, time_limit: float = LP_TIME_LIMIT_S, wanted=None):
    """LP relaxation of the multi-cover over the given samples: (optimum, x, False), or
    (None, None, stopped) when it was not solved, ``stopped`` when for want of time.

    min sum x subject to, for each sample, the x of the candidates imaging it summing to at
    least ``min_views``, with 0 <= x <= 1; with ``wanted`` (candidates x samples), also the x of
    the candidates a sample wants summing to at least 1 wherever there are any. The triangulation rule is left out, so the optimum
    bounds from below the shot count of any plan covering those samples from these candidates.

    Parameters
    ----------
    vis : scipy.sparse.csr_matrix
        Candidates by samples.
    samples : (n,) int
        The samples covered.
    min_views : int
        Views each needs.
    time_limit : float
        Seconds.
    wanted : scipy.sparse.csr_matrix, optional
        Candidates by samples.

    Returns
    -------
    optimum : float or None
        The LP's optimum.
    x : (c,) float or None
        The LP's solution.
    stopped : bool
        Whether it stopped at its time limit.
    """
    from scipy.optimize import linprog

    samples = np.asarray(samples, dtype=np.int64)
    n_cand = vis.shape[0]
    if len(samples) == 0:
        return 0.0, np.zeros(n_cand), False
    a = vis[:, samples].T.tocsr().astype(float)
    rhs = np.full(a.shape[0], float(min_views))
    if wanted is not None:
        w = sp.csr_matrix(wanted).T.tocsr().astype(float)
        w = w[np.flatnonzero(np.diff(w.indptr) > 0)]
        a = sp.vstack([a, w]).tocsr()
        rhs = np.concatenate([rhs, np.ones(w.shape[0])])
    a.sort_indices()
    # Identical constraints add nothing: keep one row per distinct set of candidates.
    keys = {}
    for r in range(a.shape[0]):
        key = a.indices[a.indptr[r]:a.indptr[r + 1]].tobytes()
        if key not in keys or rhs[r] > rhs[keys[key]]:
            keys[key] = r
    rows = np.array(sorted(keys.values()))
    a, rhs = a[rows], rhs[rows]
    used = np.flatnonzero(np.asarray(a.sum(axis=0)).ravel() > 0)
    a = a[:, used]
    res = linprog(np.ones(a.shape[1]), A_ub=-a, b_ub=-rhs,
                  bounds=(0, 1), method="highs-ipm", options={"time_limit": float(time_limit)})
    if res.status != 0 or res.x is None:
        return None, None, res.status == 1  # 1: HiGHS stopped at its time (or iteration) limit
    x = np.zeros(n_cand)
    x[used] = np.clip(res.x, 0.0, 1.0)
    return float(res.fun), x, False
