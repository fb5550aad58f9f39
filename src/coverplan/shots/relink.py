"""Links judged where the evaluator judges them: on the check samples.

The planner links its shots on its own samples, 1-2 m apart. Whether two photos share 30 %
of what they see is then counted on a few dozen samples each, and a link at the edge of the
rule can fall either side of it on the evaluator's samples 0.25 m apart: the ring prism's
plan for a Phantom 4 Pro was one piece on the planner's samples and four (the largest 139 of
181 photos) on the evaluator's. The check samples are as fine as the evaluator's or finer,
and the check already knows which of them every shot images (by the evaluator's rule), so
the plan's links are judged again on them. Where they fall into pieces or leave a photo
short of neighbours, the candidates that link (on the planner's samples) to a photo in need
or to two pieces get their views on the check samples, and ``connect_shots`` adds those
that bridge, judged on the same samples.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from coverplan.shots.connecting import connect_shots
from coverplan.shots.reconstructability import MatchRule, candidate_links, extend_links
from coverplan.shots.visibility import imaging_pairs


def relink_on_check(problem, closer, chosen: np.ndarray, rule: MatchRule, coarse_vis: sp.csr_matrix) -> np.ndarray:
    """``chosen`` (candidate indices) with the shots added that its links on the check samples
    need: one piece, ``rule.min_neighbours`` per photo, where a candidate that links (on the
    planner's samples, ``coarse_vis``: candidates x those samples) to a photo short of
    neighbours, or to photos in two pieces, can give it.

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

    Returns
    -------
    (m,) int
        ``chosen`` and the shots added.
    """
    chosen = np.asarray(chosen, dtype=np.int64)
    fine = closer.fine
    vis = check_views(closer, chosen, len(problem.cands))
    positions = problem.cands.positions
    links = candidate_links(vis, positions[chosen], fine.points, rule, normals=fine.normals)
    n_pieces, piece = connected_components(links, directed=False)
    short = np.asarray(links.sum(axis=1)).ravel() < rule.min_neighbours
    if n_pieces <= 1 and not short.any():
        return chosen
    near = coarse_links(problem, coarse_vis, chosen, rule)  # shots x candidates
    member = sp.csr_matrix((np.ones(len(chosen)), (piece, np.arange(len(chosen)))), shape=(n_pieces, len(chosen)))
    pieces_reached = np.asarray(((member @ near) > 0).sum(axis=0)).ravel()
    helps_short = np.asarray(near[np.flatnonzero(short)].sum(axis=0)).ravel() > 0
    useful = (pieces_reached >= 2) | helps_short
    useful[chosen] = False
    extra = np.flatnonzero(useful)
    if len(extra) == 0:
        return chosen
    pool, vis, every = judged_pool(problem, closer, vis, links, chosen, extra, rule)  # the shots' own links
    linked = connect_shots(vis, positions[pool], fine.points, np.arange(len(chosen)), rule, links=every)
    return pool[linked]


def check_views(closer, chosen: np.ndarray, n_cands: int) -> sp.csr_matrix:
    """Which check samples each of the ``chosen`` candidates images, as the check counted
    them: (len(chosen), check samples) ones.

    Parameters
    ----------
    closer : GapCloser
        Holds the check's views.
    chosen : (k,) int
        Candidate indices.
    n_cands : int
        Candidates.

    Returns
    -------
    scipy.sparse.csr_matrix
        (k, check samples).
    """
    who, at = closer.all_views()
    mine = np.isin(who, chosen)
    row_of = np.full(n_cands, -1, dtype=np.int64)
    row_of[chosen] = np.arange(len(chosen))
    return sp.csr_matrix((np.ones(int(mine.sum())), (row_of[who[mine]], at[mine])), shape=(len(chosen), len(closer.fine)))


def new_check_views(problem, closer, extra: np.ndarray) -> sp.csr_matrix:
    """Which check samples the candidates ``extra`` (not yet judged on them) image, by the
    evaluator's rule: (len(extra), check samples) ones.

    Parameters
    ----------
    problem : CoverProblem
        The candidates.
    closer : GapCloser
        Holds the check samples.
    extra : (k,) int
        Candidate indices.

    Returns
    -------
    scipy.sparse.csr_matrix
        (k, check samples).
    """
    fine = closer.fine
    c = problem.cands.subset(extra)
    cam, pt, _ = imaging_pairs(c.positions, c.heading_deg, c.pitch_deg, problem.camera, fine.points, fine.normals,
                               problem.scene.rays, max_range=problem.limits.d_opt,
                               max_incidence_deg=problem.limits.max_incidence_deg, offset=problem.scene.epsilon * 4,
                               point_tree=closer.tree)
    return sp.csr_matrix((np.ones(len(cam)), (cam, pt)), shape=(len(extra), len(fine)))


def coarse_links(problem, coarse_vis: sp.csr_matrix, chosen: np.ndarray, rule: MatchRule) -> sp.csr_matrix:
    """Links from the ``chosen`` shots to every candidate on the planner's samples
    (``coarse_vis``: candidates x those samples): (len(chosen), candidates).

    Parameters
    ----------
    problem : CoverProblem
        The candidates and the samples.
    coarse_vis : scipy.sparse.csr_matrix
        Candidates by the planner's samples.
    chosen : (k,) int
        Candidate indices.
    rule : MatchRule
        The matching rule.

    Returns
    -------
    scipy.sparse.csr_matrix
        (k, candidates) links.
    """
    coarse, coarse_normals = (a[:coarse_vis.shape[1]] for a in (problem.samples.points, problem.samples.normals))
    return candidate_links(coarse_vis, problem.cands.positions, coarse, rule, rows=chosen,
                           normals=coarse_normals)[chosen].tocsr()


def judged_pool(problem, closer, vis: sp.csr_matrix, links, chosen: np.ndarray, extra: np.ndarray,
                rule: MatchRule) -> tuple[np.ndarray, sp.csr_matrix, sp.csr_matrix]:
    """The ``chosen`` shots and the candidates ``extra`` after them, with the views of all of
    them on the check samples and their links judged there.

    Parameters
    ----------
    problem : CoverProblem
        The candidates.
    closer : GapCloser
        Holds the check samples.
    vis : scipy.sparse.csr_matrix
        The chosen shots' views on the check samples (``check_views``).
    links : (k, k) sparse
        Their links on the check samples.
    chosen, extra : (k,), (j,) int
        Candidate indices.
    rule : MatchRule
        The matching rule.

    Returns
    -------
    pool : (k + j,) int
        ``chosen`` then ``extra``.
    vis : scipy.sparse.csr_matrix
        (k + j, check samples) views.
    links : scipy.sparse.csr_matrix
        (k + j, k + j) links.
    """
    fine = closer.fine
    pool = np.concatenate([chosen, extra])
    vis = sp.vstack([vis, new_check_views(problem, closer, extra)]).tocsr()
    return pool, vis, extend_links(vis, problem.cands.positions[pool], fine.points, rule, links, normals=fine.normals)


def take_greedily(links: sp.spmatrix, n_chosen: int, budget: int, score) -> tuple[np.ndarray, bool]:
    """Rows of a pool (the first ``n_chosen`` taken) taken one at a time, each the one
    ``score`` rates highest, until ``score`` finds nothing left to mend, no rating is above
    zero, the pool is spent or ``budget`` rows are taken.

    Parameters
    ----------
    links : (p, p) sparse
        Links among the pool.
    n_chosen : int
        Rows taken from the start.
    budget : int
        The most rows taken beyond them.
    score : callable
        ``score(among, to_taken)`` with the links among the taken rows and from the rest to
        them: the rest's ratings, or None when nothing is left to mend.

    Returns
    -------
    taken : (p,) bool
        The rows taken.
    done : bool
        Whether ``score`` found nothing left to mend.
    """
    taken = np.zeros(links.shape[0], dtype=bool)
    taken[:n_chosen] = True
    while True:
        rows, rest = np.flatnonzero(taken), np.flatnonzero(~taken)
        gain = score(links[rows][:, rows], links[rest][:, rows])
        if gain is None:
            return taken, True
        if len(rest) == 0 or len(rows) - n_chosen >= budget:
            return taken, False
        best = int(np.argmax(gain))
        if gain[best] <= 0:
            return taken, False
        taken[rest[best]] = True
