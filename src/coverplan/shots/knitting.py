"""No group of photos on a thin bridge: links knitted until every sizeable group of photos is
joined to the rest by at least ``MatchRule.min_cut`` links.

Bracing (bracing.py) leaves no photo the set hangs on, but a whole group can still hang on two
links to two different photos. The square's lanes plan without edge views at a 50 deg pair
rule was one piece with no cut photo on the evaluator's samples; its roof grid (16 photos) was
joined to the façades by two links, both to tilted linking shots, and in the field neither
matched: the roof came back as a second model. Counting links across every cut of the graph
(its k-edge-connected classes) finds such a group; knitting adds candidates that link into it
and into the largest class, until the two are one class, nothing helps or the budget is spent.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, connected_components, dijkstra, maximum_flow

from coverplan.shots.reconstructability import MatchRule, candidate_links
from coverplan.shots.relink import check_views, coarse_links, judged_pool, new_check_views, take_greedily

MIN_GROUP = 4  # photos in a group worth knitting: smaller ones are single photos and short runs, which
# the neighbour count and bracing look after
MAX_POOL = 400  # candidates judged on the check samples, those knitting most on the planner's
MAX_ROUNDS = 4  # pools drawn afresh for the groups as knitting leaves them


def edge_classes(links: sp.spmatrix, min_cut: int) -> np.ndarray:
    """Label per shot of its class: shots that no cut of fewer than ``min_cut`` links separates.

    The cuts are read off a flow-equivalent tree (Gusfield's: one maximum flow per shot, on
    scipy's Dinic), whose path between two shots has the fewest links any cut between them
    has at its lightest edge; the classes are the tree's pieces once its edges lighter than
    ``min_cut`` are gone.

    Parameters
    ----------
    links : (n, n) sparse or dense
        Symmetric links.
    min_cut : int
        The fewest links a cut between two shots of one class has.

    Returns
    -------
    (n,) int
        Class labels, 0 the largest class, then by falling size.
    """
    g = sp.csr_matrix(links, dtype=np.int32)
    g.setdiag(0)
    g.eliminate_zeros()
    g.data[:] = 1
    n = g.shape[0]
    parent = np.zeros(n, dtype=np.int64)
    weight = np.zeros(n, dtype=np.int64)
    for s in range(1, n):
        t = int(parent[s])
        flow = maximum_flow(g, s, t, method="dinic")
        weight[s] = flow.flow_value
        residual = (g - flow.flow).tocsr()
        residual.data = (residual.data > 0).astype(np.int32)
        residual.eliminate_zeros()
        side = np.zeros(n, dtype=bool)
        side[breadth_first_order(residual, s, directed=True, return_predecessors=False)] = True
        later = np.arange(n) > s
        parent[later & side & (parent == t)] = s
    keep = np.flatnonzero(weight >= min_cut)
    keep = keep[keep > 0]
    tree = sp.csr_matrix((np.ones(len(keep)), (keep, parent[keep])), shape=(n, n))
    _n, label = connected_components(tree, directed=False)
    order = np.argsort(-np.bincount(label), kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rank[label].astype(np.int64)


def thin_groups(label: np.ndarray, min_group: int = MIN_GROUP) -> np.ndarray:
    """Labels of the classes (``edge_classes``) of at least ``min_group`` shots beyond the
    largest: the groups joined to the rest by fewer than the classes' ``min_cut`` links.

    Parameters
    ----------
    label : (n,) int
        The shots' classes, 0 the largest.
    min_group : int
        Shots a group needs to count.

    Returns
    -------
    (g,) int
        Class labels.
    """
    sizes = np.bincount(label)
    return np.flatnonzero(sizes >= min_group)[1:] if len(sizes) else np.zeros(0, dtype=np.int64)


def knitting_gain(to_shots: sp.csr_matrix, label: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Per candidate: the links it adds across the cuts between the thin ``groups`` and the
    largest class: per group, the fewer of its links into the group and into the largest class
    (each such pair of links is one more path between the two).

    Parameters
    ----------
    to_shots : (m, k) sparse
        Links from m candidates to the k shots.
    label : (k,) int
        The shots' classes, 0 the largest.
    groups : (g,) int
        Labels of the thin groups.

    Returns
    -------
    (m,) int
        Paths each candidate adds, summed over the groups.
    """
    to_shots = sp.csr_matrix(to_shots, copy=True)
    to_shots.eliminate_zeros()
    to_shots.data[:] = 1.0
    into_main = to_shots @ (label == 0).astype(float)
    gain = np.zeros(to_shots.shape[0], dtype=np.int64)
    for g in np.asarray(groups):
        gain += np.minimum(to_shots @ (label == g).astype(float), into_main).astype(np.int64)
    return gain


def knitting_chain(known: sp.spmatrix, chosen: np.ndarray, label: np.ndarray, group: int) -> np.ndarray:
    """The untaken candidates on the shortest chain of links from a shot of ``group`` to a shot
    of the largest class (label 0) that steps onto no other taken shot on the way, so that the
    chain is one more path between them.

    Parameters
    ----------
    known : (c, c) sparse
        Symmetric links among candidates.
    chosen : (k,) int
        Candidate indices of the shots.
    label : (k,) int
        The shots' classes.
    group : int
        The group's label.

    Returns
    -------
    (j,) int
        Candidate indices, empty when no chain exists.
    """
    n = known.shape[0]
    inside = chosen < n
    taken = np.zeros(n, dtype=bool)
    taken[chosen[inside]] = True
    g = sp.coo_matrix(known)
    keep = (g.row != g.col) & ~(taken[g.row] & taken[g.col]) & (g.data != 0)
    g = sp.csr_matrix((np.ones(int(keep.sum())), (g.row[keep], g.col[keep])), shape=(n, n))
    sources = chosen[inside & (label == group)]
    targets = chosen[inside & (label == 0)]
    if not len(sources) or not len(targets):
        return np.zeros(0, dtype=np.int64)
    # Taken shots end a chain: no edges out of them except from the group's own shots.
    out_ok = ~taken
    out_ok[sources] = True
    g = sp.diags(out_ok.astype(float)) @ g
    dist, pred, _src = dijkstra(g, directed=True, indices=sources, unweighted=True, min_only=True,
                                return_predecessors=True)
    end = targets[np.argmin(dist[targets])]
    if not np.isfinite(dist[end]):
        return np.zeros(0, dtype=np.int64)
    chain, node = [], pred[end]
    while node >= 0 and not taken[node]:
        chain.append(int(node))
        node = pred[node]
    return np.array(chain, dtype=np.int64)


def knit_links(problem, closer, chosen: np.ndarray, rule: MatchRule, coarse_vis: sp.csr_matrix,
               max_added: int | None = None, known: sp.spmatrix | None = None) -> np.ndarray:
    """``chosen`` (candidate indices) with the candidates added that join its thin groups to
    the rest on the check samples, one at a time the one knitting most groups, until no group
    of ``MIN_GROUP`` photos or more is joined by fewer than ``rule.min_cut`` links, nothing
    helps or ``max_added`` (default: a tenth of the shots) are added. Where no single candidate
    links into a group and into the largest class, the shortest chain of candidates between
    them over ``known`` (the candidates' links on the planner's samples) is added instead and
    judged in the next round.

    Parameters
    ----------
    problem : CoverProblem
        The candidates and the check samples.
    closer : GapCloser
        Judges links on the check samples.
    chosen : (k,) int
        Candidate indices.
    rule : MatchRule
        The matching rule; ``min_cut`` below 2 asks nothing.
    coarse_vis : scipy.sparse.csr_matrix
        Candidates by the planner's samples.
    max_added : int, optional
        The most candidates added.
    known : (c, c) sparse, optional
        Links among the first c candidates on the planner's samples, for chains.

    Returns
    -------
    (m,) int
        ``chosen`` with the added candidates after it.
    """
    chosen = np.asarray(chosen, dtype=np.int64)
    if rule.min_cut < 2 or len(chosen) < 2 * MIN_GROUP:
        return chosen
    budget = max(1, len(chosen) // 10) if max_added is None else int(max_added)
    start = len(chosen)
    for _round in range(MAX_ROUNDS):
        chosen, done = _knit_round(problem, closer, chosen, rule, coarse_vis, budget - (len(chosen) - start), known)
        if done or len(chosen) - start >= budget:
            break
    return chosen


def _knit_round(problem, closer, chosen: np.ndarray, rule: MatchRule, coarse_vis: sp.csr_matrix,
                budget: int, known: sp.spmatrix | None = None) -> tuple[np.ndarray, bool]:
    """One round of ``knit_links``: a pool of candidates that knit the groups as they are now,
    taken greedily; returns the shots and whether no thin group is left."""
    fine = closer.fine
    positions = problem.cands.positions
    vis = check_views(closer, chosen, len(problem.cands))
    unseen = np.flatnonzero(np.diff(vis.indptr) == 0)  # shots added after the check (links, bracing)
    if len(unseen):
        vis = vis.tolil()
        vis[unseen] = new_check_views(problem, closer, chosen[unseen])
        vis = vis.tocsr()
    links = candidate_links(vis, positions[chosen], fine.points, rule, normals=fine.normals)
    label = edge_classes(links, rule.min_cut)
    groups = thin_groups(label)
    if len(groups) == 0:
        return chosen, True
    near = coarse_links(problem, coarse_vis, chosen, rule).T.tocsr()  # candidates x shots
    gain = knitting_gain(near, label, groups)
    gain[chosen] = 0
    extra = np.flatnonzero(gain > 0)
    if len(extra) == 0:
        if known is None:
            return chosen, False
        chains = [knitting_chain(known, chosen, label, g) for g in groups]
        added = np.unique(np.concatenate(chains))[:budget]
        return np.concatenate([chosen, added]), False
    extra = extra[np.argsort(-gain[extra], kind="stable")[:MAX_POOL]]
    pool, _vis, every = judged_pool(problem, closer, vis, links, chosen, extra, rule)

    def score(among, to_taken):
        label = edge_classes(among, rule.min_cut)
        groups = thin_groups(label)
        return None if len(groups) == 0 else knitting_gain(to_taken, label, groups)

    taken, done = take_greedily(every, len(chosen), budget, score)
    return np.concatenate([chosen, pool[len(chosen):][taken[len(chosen):]]]), done
