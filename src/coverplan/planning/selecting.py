"""Choosing the shots on the planner's samples: lanes, the cover, sharp and framed views, links."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from coverplan.errors import PlanningError
from coverplan.planning.problem import Problem
from coverplan.planning.setup import Setup
from coverplan.progress import Progress
from coverplan.shots.connecting import connect_shots
from coverplan.shots.edge_views import required_edge_views
from coverplan.shots.framing import (
    framed_view_matrix,
    view_fill,
)
from coverplan.shots.lane_selection import select_lanes
from coverplan.shots.reconstructability import MatchRule
from coverplan.shots.selection import select_views
from coverplan.shots.sharpness import add_sharp_views, add_wanted_views, incidence_deg, sharp_view_matrix


@dataclass(frozen=True)
class Selection:
    """The shots chosen on the planner's samples and how many each step added.

    Parameters
    ----------
    chosen : (k,) int
        The chosen candidates.
    covering : int
        Shots chosen by the covering LP.
    sharpening : int
        Shots added for sharp views.
    framing : int
        Shots added for framed views.
    lp_bound : float or None
        The LP's lower bound of the shot count.
    lp_stopped : bool
        True when the LP stopped at its time limit.
    lane_rows : (l,) int
        Candidates chosen as lanes.
    required : (r,) int
        Candidates every plan keeps.
    """

    chosen: np.ndarray  # (k,) int candidate indices
    covering: int
    sharpening: int
    framing: int
    lp_bound: float | None
    lp_stopped: bool  # the LP reached its time limit (selection.Selection.lp_stopped)
    lane_rows: np.ndarray  # (k,) int candidate indices of the lane photos chosen (settings.selection "lanes")
    required: np.ndarray  # (k,) int candidate indices of the edge views taken, those no lane photo stands in for

    def keep(self, problem: Problem) -> np.ndarray:
        """(k,) candidate indices no later stage drops: the photos already taken, the edge views
        and the lanes.

        Parameters
        ----------
        problem : Problem
            Gives the photos already taken.

        Returns
        -------
        (k,) int
            Sorted candidate indices.
        """
        return np.union1d(np.union1d(problem.fixed, self.required), self.lane_rows)


def select_shots(problem: Problem, setup: Setup, progress: Progress) -> Selection:
    """View selection (covering LP), then sharp views and links for SfM.

    Parameters
    ----------
    problem : Problem
        The samples and candidates.
    setup : Setup
        The resolved settings.
    progress : Progress
        Reports the stages.

    Returns
    -------
    Selection
        The chosen shots.
    """
    settings, match = setup.asked, setup.match
    cam, pt, _ = problem.cover.pairs
    samples, cands = problem.samples, problem.cover.cands
    inc = None  # the views' incidences, for the sharp and framed views
    if match is not None and (match.sharp_views or match.framed_views):
        inc = incidence_deg(cam, pt, cands.positions, samples.points, samples.normals)
    # Lean selection (``lean``): the cover is chosen with a sharp view for every sample in view,
    # not patched with them after.
    wanted = sharp_view_matrix(cam, pt, inc, len(cands), len(samples)) \
        if lean(match) and match.sharp_views else None
    lane_rows = np.zeros(0, dtype=np.int64)
    required = problem.required
    if len(problem.lanes):
        with progress.stage("lane selection"):
            lane_rows = select_lanes(problem.vis, problem.lanes, samples.area, settings.min_views)
            if settings.edge_views:  # a lane photo round a corner stands in for the corner's edge views
                required = required_edge_views(cands, setup.camera, setup.standoff, problem.vis.getnnz(axis=1),
                                               taken=cands.subset(np.union1d(problem.fixed, lane_rows)))
    preset = np.union1d(np.union1d(problem.fixed, required), lane_rows)
    with progress.stage("view selection", unit="shot") as update:
        selection = select_views(problem.vis, problem.rays, settings.min_views, setup.min_triangulation_deg,
                                 lp_time_limit=settings.lp_time_limit, progress=update, max_pair_deg=setup.max_pair_deg,
                                 preset=preset if len(preset) else None, wanted=wanted)
    chosen = selection.chosen
    covering = len(chosen)
    if match is not None and match.sharp_views and len(chosen):
        with progress.stage("sharp views for SfM"):
            chosen = add_sharp_views(cam, pt, inc, len(cands), samples.area, chosen, views=match.sharp_views)
    sharpening = len(chosen) - covering
    if match is not None and match.framed_views and len(chosen):
        with progress.stage("framed views for SfM"):
            framed = framed_view_matrix(cam, pt, view_fill(problem.fill, cam, pt, samples.normals), inc, len(cands),
                                        len(samples))
            chosen = add_wanted_views(framed, samples.area, chosen, views=match.framed_views)
    framing = len(chosen) - covering - sharpening
    if match is not None and len(chosen):
        with progress.stage("linking shots for SfM"):
            chosen = connect_shots(problem.vis, cands.positions, samples.points, chosen, match,
                                   links=problem.links_job.result())
    if len(chosen) == 0:
        reason = problem.reach.reason
        raise PlanningError("no safe viewpoint can image any part of the target: "
                            + (reason[0] if len(reason) and reason[0] else "check the security distance and GSD"))
    return Selection(chosen, covering, sharpening, framing, selection.lp_bound, selection.lp_stopped, lane_rows,
                     required)


def lean(match: MatchRule | None) -> bool:
    """Whether the plan is chosen lean: the cover with its sharp views, pieces joined through
    the chains already added (``connect_shots``), and a final trim (``gaps._trim``). Only under the
    "samples" link test: under "centroid" the same rules met with fewer photos split the gabled
    house's model in two field draws of three (its links across corners are not COLMAP's), so
    those plans keep the slack the classic selection leaves (docs/reconstruction.md).

    Parameters
    ----------
    match : MatchRule or None
        The matching rule; None plans without one.

    Returns
    -------
    bool
        True for a lean plan.
    """
    return match is not None and match.lean
