"""No photo the set hangs on: links braced so that losing one photo splits nothing.

A link graph that is one piece can still be a chain: the gabled house's default plan was
38 photos in one piece, but 16 of them were cut vertices (articulation points), each the only
link between the photos before it and those after. Under field conditions one of those
pairs fails to match now and then, and the photos beyond it come back as a second model
(docs/reconstruction.md: the west gable's eight photos, one draw in three). Bracing adds
candidates that link to photos on both sides of such a photo, until none is left or no
candidate helps, judged on the check samples as ``relink_on_check`` judges links.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from coverplan.shots.link_graph import cut_shots, depth_first
from coverplan.shots.reconstructability import MatchRule, candidate_links
from coverplan.shots.relink import check_views, coarse_links, judged_pool, take_greedily


def bracing_gain(among: sp.csr_matrix, to_shots: sp.csr_matrix, cuts: np.ndarray) -> np.ndarray:
    """Per candidate: how many of the ``cuts`` it would brace, by linking to shots on two
    sides of the cut.

    Parameters
    ----------
    among : (k, k) sparse
        Symmetric links among the plan's shots.
    to_shots : (m, k) sparse
        Links from m candidates to the shots.
    cuts : (c,) int
        Cut shots of ``among`` (``cut_shots``).

    Returns
    -------
    (m,) int
        Cuts each candidate braces.
    """
    among, to_shots = sp.csr_matrix(among), sp.csr_matrix(to_shots, copy=True)
    to_shots.eliminate_zeros()  # a stored zero is no link
    k = among.shape[0]
    gain = np.zeros(to_shots.shape[0], dtype=np.int64)
    if len(cuts) == 0 or to_shots.nnz == 0:
        return gain
    # The pieces left when a cut shot goes are read off one depth-first search: each child
    # subtree whose low-link does not reach above the cut is a piece of its own (its preorder
    # numbers are one run), the rest of the cut's tree is one more, other trees stay as they are.
    dfs = depth_first(among)
    order, low, parent, size = dfs["order"], dfs["low"], dfs["parent"], dfs["size"]
    by_order = np.argsort(order)
    shot = to_shots.indices
    has = np.diff(to_shots.indptr) > 0
    starts = to_shots.indptr[:-1][has]
    for a in np.asarray(cuts, dtype=np.int64):
        label = dfs["root"].copy()
        children = np.flatnonzero((parent == a) & (low >= order[a]))
        lift = k + children - dfs["root"][a]  # each separating child's piece gets the label k + child
        run = np.zeros(k + 1, dtype=np.int64)  # +lift over the child's preorder run
        np.add.at(run, order[children], lift)
        np.add.at(run, order[children] + size[children], -lift)
        label[by_order] += np.cumsum(run)[:k]
        mine = label[shot]
        skip = shot == a  # links to the cut itself join nothing once it is gone
        high = np.maximum.reduceat(np.where(skip, -1, mine), starts)
        lowest = np.minimum.reduceat(np.where(skip, 2 * k + 1, mine), starts)
        gain[has] += (high >= 0) & (lowest <= 2 * k) & (high != lowest)
    return gain


MAX_POOL = 400  # candidates judged on the check samples, those bracing most on the planner's


def brace_links(problem, closer, chosen: np.ndarray, rule: MatchRule, coarse_vis: sp.csr_matrix,
                max_added: int | None = None) -> np.ndarray:
    """``chosen`` (candidate indices) with the candidates added that brace its cut shots on
    the check samples, one at a time the one bracing most, until none is left, nothing helps
    or ``max_added`` (default: a quarter of the shots) are added.

    Candidates are those that brace a cut by their links on the planner's samples
    (``coarse_vis``: candidates x those samples); their links are then judged on the check
    samples.

    Parameters
    ----------
    problem : CoverProblem
        The candidates and the check samples.
    closer : GapCloser
        Judges links on the check samples.
    chosen : (k,) int
        Candidate indices.
    rule : MatchRule
        The matching rule.
    coarse_vis : scipy.sparse.csr_matrix
        Candidates by the planner's samples.
    max_added : int, optional
        The most candidates added.

    Returns
    -------
    (m,) int
        ``chosen`` with the added candidates after it.
    """
    chosen = np.asarray(chosen, dtype=np.int64)
    if len(chosen) < 3:
        return chosen
    budget = max(1, len(chosen) // 4) if max_added is None else int(max_added)
    fine = closer.fine
    positions = problem.cands.positions
    vis = check_views(closer, chosen, len(problem.cands))
    links = candidate_links(vis, positions[chosen], fine.points, rule, normals=fine.normals)
    cuts = cut_shots(links)
    if len(cuts) == 0:
        return chosen
    near = coarse_links(problem, coarse_vis, chosen, rule).T.tocsr()  # candidates x shots
    gain = bracing_gain(links, near, cuts)
    gain[chosen] = 0
    extra = np.flatnonzero(gain > 0)
    if len(extra) == 0:
        return chosen
    extra = extra[np.argsort(-gain[extra], kind="stable")[:MAX_POOL]]
    pool, _vis, every = judged_pool(problem, closer, vis, links, chosen, extra, rule)

    def score(among, to_taken):
        cuts = cut_shots(among)
        return None if len(cuts) == 0 else bracing_gain(among, to_taken, cuts)

    taken, _done = take_greedily(every, len(chosen), budget, score)
    return np.concatenate([chosen, pool[len(chosen):][taken[len(chosen):]]])
