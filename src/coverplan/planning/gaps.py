"""Closing the gaps on the check samples: repair, sharp views, redundancy, relinking, the final trim."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from coverplan.planning.problem import Problem, fill_of
from coverplan.planning.selecting import Selection, lean
from coverplan.planning.setup import Setup
from coverplan.progress import Progress
from coverplan.shots.bracing import brace_links
from coverplan.shots.connecting import connect_shots
from coverplan.shots.cover import CoverProblem
from coverplan.shots.framing import (
    framed_view_matrix,
    view_fill,
)
from coverplan.shots.knitting import knit_links
from coverplan.shots.reconstructability import MatchRule, candidate_links, extend_links, shot_links
from coverplan.shots.redundancy import TRIM_SPARE_VIEWS, CheckViews, SharpViews, drop_redundant
from coverplan.shots.relink import check_views, relink_on_check
from coverplan.shots.repair import MAX_ROUNDS, TARGET_PCT, GapCloser
from coverplan.shots.selection import select_views
from coverplan.shots.sharpness import SHARP_INCIDENCE_DEG, best_incidence, incidence_deg, sharp_view_matrix
from coverplan.shots.visibility import view_rays


@dataclass(frozen=True)
class ClosedGaps:
    """The shots after the fine check: repaired, sharpened, thinned and relinked.

    ``cover`` is the problem grown by the repair's candidates and the check samples.

    Parameters
    ----------
    cover : CoverProblem
        The cover problem grown by the repair.
    chosen : (k,) int
        The chosen candidates.
    check : object
        The fine check of ``chosen``.
    closer : GapCloser
        The repair that grew ``cover``.
    history : list of float
        Coverage in percent after each repair round.
    fine_sharp : int
        Shots added for sharp views on the check samples.
    complete : int
        Shots before the redundant ones were dropped.
    dropped : int
        Redundant shots dropped.
    check_links : int
        Shots added to link what the check samples ask.
    trimmed : int
        Shots trimmed at the end.
    """

    cover: CoverProblem
    chosen: np.ndarray  # (k,) int candidate indices into cover.cands
    check: object  # repair.Check of ``chosen``
    closer: GapCloser
    history: list
    fine_sharp: int
    complete: int
    dropped: int
    check_links: int
    trimmed: int  # shots the final trim dropped (``_trim``)


def close_gaps(problem: Problem, selection: Selection, setup: Setup, progress: Progress) -> ClosedGaps:
    """Judge the shots on the check samples; add shots where they fall short, drop the
    redundant ones, link what the check's samples ask.

    Parameters
    ----------
    problem : Problem
        The samples and candidates.
    selection : Selection
        The shots chosen on the planner's samples.
    setup : Setup
        The resolved settings.
    progress : Progress
        Reports the repair rounds.

    Returns
    -------
    ClosedGaps
        The shots after the check.
    """
    settings, match, d_opt = setup.asked, setup.match, setup.d_opt
    samples, coarse = problem.samples, len(problem.samples)
    cover = replace(problem.cover)  # the repair grows its own copy of the problem
    chosen, vis = selection.chosen, problem.vis
    known = problem.links_job.result() if problem.links_job is not None else None
    with progress.stage("fine check and repair"):
        passing = settings.pass_rules.max_photo_offset_m if settings.fly == "through" else 0.0
        closer = GapCloser(cover, settings.min_views, setup.min_triangulation_deg, setup.max_pair_deg, setup.standoff,
                           setup.extra_clearance, problem.fine_job.result(), sight_m=passing)
        check = closer.check(chosen)
        history = [check.coverage_pct]
        while check.coverage_pct < TARGET_PCT and len(history) <= MAX_ROUNDS and closer.extend(check):
            vis, rays = cover.matrices()
            before = len(chosen)
            chosen = select_views(vis, rays, settings.min_views, setup.min_triangulation_deg, lp_time_limit=0,
                                  max_pair_deg=setup.max_pair_deg, preset=chosen).chosen
            if match is not None:
                # Links are judged on the planner's own samples: the check samples crowd a few
                # strips that hundreds of candidates see, which makes the pair products explode.
                chosen = _link_new_shots(vis[:, :coarse], cover.cands.positions, samples, chosen,
                                         before, match, 0.5 * d_opt, known=known)
            check = closer.check(chosen)
            history.append(check.coverage_pct)
        fine_sharp = 0
        if match is not None and match.sharp_views:
            before = len(chosen)
            chosen = closer.sharpen(chosen, match.sharp_views)
            if len(chosen) > before:  # sharpen leaves the problem as it was: vis still holds
                chosen = _link_new_shots(vis[:, :coarse], cover.cands.positions, samples, chosen,
                                         before, match, 0.5 * d_opt, known=known)
                fine_sharp = len(chosen) - before
                check = closer.check(chosen)
        complete = len(chosen)
        if match is not None:
            fill = problem.fill
            if match.framed_views:  # the repair's candidates too
                added = cover.cands.subset(np.arange(len(fill), len(cover.cands)))
                fill = np.vstack([fill, fill_of(cover.scene, added, setup)])
            chosen = _drop_redundant(cover, closer, chosen, check.covered, coarse, vis, match, fill,
                                     keep=selection.keep(problem))
            check = closer.kept(check, chosen)
        dropped = complete - len(chosen)
        check_links = 0
        if match is not None:
            kept = len(chosen)
            chosen = relink_on_check(cover, closer, chosen, match, vis[:, :coarse])
            if match.braced:
                chosen = brace_links(cover, closer, chosen, match, vis[:, :coarse])
            chosen = knit_links(cover, closer, chosen, match, vis[:, :coarse], known=known)
            check_links = len(chosen) - kept
            if check_links:
                check = closer.check(chosen)
        trimmed = 0
        if lean(match) and len(chosen) > 2:
            before = len(chosen)
            chosen = _trim(cover, closer, chosen, check, coarse, vis, match, fill, selection.keep(problem))
            trimmed = before - len(chosen)
            if trimmed:
                check = closer.kept(check, chosen)
    return ClosedGaps(cover, chosen, check, closer, history, fine_sharp, complete, dropped, check_links, trimmed)


def _link_new_shots(vis, positions, samples, chosen, before: int, match: MatchRule, radius: float,
                    known=None) -> np.ndarray:
    """connect_shots after a repair round, over the chosen shots and the candidates within
    ``radius`` of the new ones (linking over every candidate again costs seconds). ``known``:
    the links among the first candidates (``candidate_links``), which are not worked out again."""
    if len(chosen) == before:
        return chosen
    near = np.isfinite(cKDTree(positions[chosen[before:]]).query(positions, distance_upper_bound=radius)[0])
    pool = np.union1d(chosen, np.flatnonzero(near))
    links = None
    if known is not None:
        old = pool[pool < known.shape[0]]  # pool is sorted: these come first
        links = extend_links(vis[pool], positions[pool], samples.points, match, known[old][:, old],
                             normals=samples.normals)
    linked = connect_shots(vis[pool], positions[pool], samples.points, np.searchsorted(pool, chosen), match,
                           links=links, normals=samples.normals)
    return pool[linked]


def _drop_redundant(cover: CoverProblem, closer: GapCloser, chosen: np.ndarray, covered: np.ndarray,
                    coarse: int, vis, match: MatchRule, fill: np.ndarray, keep=None, links=None,
                    braced: bool = False, spare_views: int = 0) -> np.ndarray:
    """``drop_redundant`` keeping the fine check's coverage, the links between the shots, the
    sharp views (on the planner's samples as the sharp-view stage asked them, on the check
    samples a view as square as 35 deg or as the plan's best, docs/reconstruction.md) and the
    framed views on the planner's samples. ``fill``: ``frame_fill`` of every candidate."""
    n_cands = len(cover.cands)
    who, at = closer.firm_views()
    mine = np.isin(who, chosen)
    who, at = who[mine], at[mine]
    positions, fine = cover.cands.positions, closer.fine
    views = CheckViews(who, at, view_rays(who, at, positions, fine.points), covered,
                       closer.min_views, closer.min_triangulation_deg, closer.max_pair_deg)
    sharp = []
    if match.sharp_views:
        cam, pt, _ = cover.pairs
        own = pt < coarse
        inc = incidence_deg(cam[own], pt[own], positions, cover.samples.points, cover.samples.normals)
        sharp.append(SharpViews(sharp_view_matrix(cam[own], pt[own], inc, n_cands, coarse), match.sharp_views))
        inc = incidence_deg(who, at, positions, fine.points, fine.normals)
        best = np.maximum(best_incidence(at, inc, len(fine)), SHARP_INCIDENCE_DEG)
        sharp.append(SharpViews(sharp_view_matrix(who, at, inc, n_cands, len(fine), targets=best), match.sharp_views))
    if match.framed_views:
        cam, pt, _ = cover.pairs
        own = pt < coarse
        cam, pt = cam[own], pt[own]
        normals = cover.samples.normals
        inc = incidence_deg(cam, pt, positions, cover.samples.points, normals)
        sharp.append(SharpViews(framed_view_matrix(cam, pt, view_fill(fill, cam, pt, normals), inc, n_cands, coarse),
                                match.framed_views))
    if links is None:
        links = shot_links(vis[chosen][:, :coarse], positions[chosen], cover.samples.points[:coarse], match,
                           normals=cover.samples.normals[:coarse])
    return drop_redundant(chosen, views, sharp, links, match.min_neighbours, keep=keep, braced=braced,
                          spare_views=spare_views)


def _trim(cover: CoverProblem, closer: GapCloser, chosen: np.ndarray, check, coarse: int, vis, match: MatchRule,
          fill: np.ndarray, keep) -> np.ndarray:
    """The finished shots less those the rest make redundant, judged as ``_drop_redundant``
    judges them but on the links of the check samples (as the relink and the bracing judge
    them), with no new cut photo when the links are braced, and with one view to spare on
    every check sample a dropped shot covered: the plan keeps a view more than its rule asks
    wherever it had one, the margin the field runs need (docs/reconstruction.md)."""
    fine = closer.fine
    links = candidate_links(check_views(closer, chosen, len(cover.cands)), cover.cands.positions[chosen],
                            fine.points, match, normals=fine.normals).toarray() > 0
    np.fill_diagonal(links, False)
    return _drop_redundant(cover, closer, chosen, check.covered, coarse, vis, match, fill, keep=keep,
                           links=links, braced=match.braced, spare_views=TRIM_SPARE_VIEWS)
