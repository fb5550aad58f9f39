"""Close the loop between the planner's samples.

The planner optimises on samples d_opt/8 apart (1-2 m for common cameras). Between them a
window, the foot of a wall behind a fence or a roof edge can go unseen. So after selection
the shots are checked on a finer, independent sampling (``surface.check_spacing``, its own
seed), exactly as the evaluator judges them. Whatever they miss joins the covering problem:
the missed samples as new columns, their reachability probes and views along their normals
as new candidates. Then the selection is extended (the shots already chosen stay) and linked
again. This repeats until the check covers all of the reachable area (``TARGET_PCT``), nothing
more can be gained, or ``MAX_ROUNDS`` are done. What is left is reported with its reason.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from coverplan.shots.candidates import along_normals, keep_safe, thin
from coverplan.shots.check_samples import FineCheck
from coverplan.shots.cover import CHECK_BALL, CHECK_MARGIN, CoverProblem
from coverplan.shots.probe_views import around_views, from_probes
from coverplan.shots.reachability import reachability
from coverplan.shots.sharpness import add_sharp_views, incidence_deg
from coverplan.shots.surface import (
    OPPOSED_TERRACE,
    SurfaceSamples,
)
from coverplan.shots.visibility import (
    clear_around,
    has_pair_between,
    imaging_pairs_firm,
    seen_from_around,
    view_rays,
)

# Repeat while anything is missed that more shots could still image (at most MAX_ROUNDS):
# stopping at 99.9 % left samples that candidates did image listed as 'not covered by the
# selected shots' (a wall beside a shed after sharp views were added).
TARGET_PCT = 100.0
MAX_ROUNDS = 3
MAX_AROUND = 2000  # known views a dense re-probe looks around (16 x 3 probes each)
EDGE_NEAR = 2.0  # x the check spacing: a covered sample this near a hidden one is at the edge
EDGE_AROUND = 0.25  # x the check spacing: how far off an edge sample its views must see past
EDGE_REASON = "at the edge of surface no safe viewpoint sees: its views are cut off a few centimetres away"


class GapCloser:
    """Fine check of a selection, and the new samples and candidates for what it misses.

    Parameters
    ----------
    problem : CoverProblem
        The cover problem, grown by the repair.
    min_views : int
        Views a sample needs.
    min_triangulation_deg : float
        The least angle of a triangulating pair.
    max_pair_deg : float or None
        The widest angle of a matching pair.
    distance : float
        The candidates' standoff, metres.
    margin : float
        Metres beyond the security distance.
    fine : SurfaceSamples
        The check samples.
    sight_m : float
        Metres off the camera a view's sight must hold.
    """

    def __init__(self, problem: CoverProblem, min_views: int, min_triangulation_deg: float, max_pair_deg: float | None,
                 distance: float, margin: float, fine: SurfaceSamples, sight_m: float = 0.0):
        """``fine``: the check samples (``check_samples`` at ``planner_check_spacing``);
        ``sight_m``: how far off its planned point a photo may be taken (flying through)."""
        self.p = problem
        self.min_views, self.min_triangulation_deg, self.max_pair_deg = min_views, min_triangulation_deg, max_pair_deg
        self.distance, self.margin, self.sight_m = distance, margin, sight_m
        self.fine = fine
        self.ball_m = CHECK_BALL * self.fine.spacing
        self._tree = cKDTree(self.fine.points)
        n = len(self.fine)
        # (shot candidate, fine sample, whether the view holds with CHECK_MARGIN to spare)
        self._views = [np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, bool)]
        self._checked = np.zeros(0, np.int64)
        # The last check's shots and what they covered: a superset covers at least that.
        self._last = (np.zeros(0, np.int64), np.zeros(n, dtype=bool))
        self.reach_known = np.zeros(n, dtype=bool)
        self.reachable = np.zeros(n, dtype=bool)
        self.reason = np.full(n, "", dtype=object)
        self.column = np.full(n, -1, dtype=np.int64)  # fine sample -> column in the problem
        self.dense = np.zeros(n, dtype=bool)  # probed again, densely

    def check(self, chosen: np.ndarray) -> FineCheck:
        """Judge ``chosen`` (candidate indices) on the fine samples by the evaluator's rule, each
        view with ``CHECK_MARGIN`` to spare, so the claim also holds between these samples.

        Parameters
        ----------
        chosen : (k,) int
            Candidate indices.

        Returns
        -------
        FineCheck
            The verdict.
        """
        chosen = np.asarray(chosen, dtype=np.int64)
        new = np.setdiff1d(chosen, self._checked)
        if len(new):
            c = self.p.cands.subset(new)
            offset = self.p.scene.epsilon * 4
            # firm: the view holds with CHECK_MARGIN off the frustum, range and incidence, for
            # all points within ``ball_m`` of the sample
            cam, pt, _, firm = imaging_pairs_firm(
                c.positions, c.heading_deg, c.pitch_deg, self.p.camera, self.fine.points, self.fine.normals,
                self.p.scene.rays, max_range=self.p.limits.d_opt, max_incidence_deg=self.p.limits.max_incidence_deg,
                firm_shrink=CHECK_MARGIN, firm_ball_m=self.ball_m, offset=offset, point_tree=self._tree)
            # and its sight from wherever in passing the photo may be taken: a view grazing past
            # a window reveal held at the plan and was blocked where the drone took it (LOD3)
            k = np.flatnonzero(firm)
            firm[k] = seen_from_around(self.p.scene.rays, self.fine.points[pt[k]] + self.fine.normals[pt[k]] * offset,
                                       c.positions[cam[k]], self.sight_m)
            self._views = [np.concatenate([self._views[0], new[cam]]), np.concatenate([self._views[1], pt]),
                           np.concatenate([self._views[2], firm])]
            self._checked = np.union1d(self._checked, new)
        who, pt, firm = self._views
        live = np.isin(who, chosen)
        n = len(self.fine)
        views = np.bincount(pt[live], minlength=n)
        # Repair only adds shots, and more views never uncover a sample: judge only the rest.
        last, was_covered = self._last
        known = was_covered if np.isin(last, chosen).all() else np.zeros(n, dtype=bool)
        live &= firm & ~known[pt]
        covered = known | self.enough(who[live], pt[live])
        self._last = (chosen, covered)
        # Imaged by a chosen (safe) shot within range proves a sample reachable; probe the rest.
        self.reachable |= views > 0
        self.reach_known |= views > 0
        unknown = np.flatnonzero(~covered & ~self.reach_known)
        if len(unknown):
            r = reachability(self.p.scene, self.fine.subset(unknown), self.p.limits)
            self.reachable[unknown] = r.reachable
            self.reason[unknown] = r.reason
            self.reach_known[unknown] = True
        self.reason[self.reachable] = ""  # a shot added later may image what the probes missed
        return FineCheck(self.fine, covered, self.reachable.copy(), self.reason.copy())

    def kept(self, check: FineCheck, chosen: np.ndarray) -> FineCheck:
        """``check`` for a subset ``chosen`` of its shots that covers every sample it covered
        (``redundancy.drop_redundant`` keeps that): remembered, not worked out again.

        Parameters
        ----------
        check : FineCheck
            The check of a superset of ``chosen``.
        chosen : (k,) int
            Candidate indices.

        Returns
        -------
        FineCheck
            ``check``.
        """
        self._last = (np.asarray(chosen, dtype=np.int64), check.covered)
        return check

    def enough(self, who: np.ndarray, pt: np.ndarray) -> np.ndarray:
        """Per check sample: whether the views (candidate ``who`` images sample ``pt``) are
        enough, and hold a pair in the angle window.

        Parameters
        ----------
        who, pt : (m,) int
            Candidate and check sample of each view.

        Returns
        -------
        (n,) bool
            Per check sample.
        """
        n = len(self.fine)
        rays = view_rays(who, pt, self.p.cands.positions, self.fine.points)
        return (np.bincount(pt, minlength=n) >= self.min_views) & has_pair_between(pt, rays, n, self.min_triangulation_deg,
                                                                                   self.max_pair_deg)

    def edge_of_hidden(self, check: FineCheck, chosen: np.ndarray) -> FineCheck:
        """``check`` with the covered samples beside hidden surface judged again, each view
        also from points ``EDGE_AROUND`` x the spacing off the sample. Where what nothing safe
        sees begins (behind a tree's crown), the evaluator's samples between the last covered
        sample and the first hidden one are reachable yet lose their views: a claim of 100 %
        stood 0.15 pp above the evaluator on a house with a crown against its wall.

        Parameters
        ----------
        check : FineCheck
            The check.
        chosen : (k,) int
            Candidate indices.

        Returns
        -------
        FineCheck
            The check with ``edge`` set.
        """
        hidden = ~check.reachable
        if not hidden.any():
            return check
        pts = self.fine.points
        near = cKDTree(pts[hidden]).query(pts, distance_upper_bound=EDGE_NEAR * self.fine.spacing)[0]
        rows = np.flatnonzero(np.isfinite(near) & check.covered & check.reachable)
        if len(rows) == 0:
            return check
        who, pt, firm = self._views
        mine = np.zeros(len(self.fine), dtype=bool)
        mine[rows] = True
        k = np.flatnonzero(firm & mine[pt] & np.isin(who, chosen))
        cams = self.p.cands.positions[who[k]]
        seen = clear_around(self.p.scene.rays, pts[pt[k]], self.fine.normals[pt[k]], cams,
                            EDGE_AROUND * self.fine.spacing, 4.0 * self.ball_m)
        k = k[seen]
        edge = np.zeros(len(self.fine), dtype=bool)
        edge[rows] = ~self.enough(who[k], pt[k])[rows]
        if not edge.any():
            return check
        return FineCheck(check.samples, check.covered & ~edge, check.reachable, check.reason, edge)

    def extend(self, check: FineCheck) -> int:
        """Add the reachable missed samples not yet in the problem, with candidates for them,
        and probe again for those already in it. Returns how many samples got candidates.

        Parameters
        ----------
        check : FineCheck
            The last check.

        Returns
        -------
        int
            Samples that got candidates.
        """
        todo = np.flatnonzero(check.missed & check.reachable & (self.column < 0))
        again = np.flatnonzero(check.missed & check.reachable & (self.column >= 0))
        if len(again):
            self._probe_again(again)
        if len(todo) == 0:
            return len(again)
        sub = self.fine.subset(todo)
        limits = self.p.limits
        seeds = self._seeds(sub)
        # Neighbouring seeds' probes nearly coincide: 8 probes of 96 directions per seed doubled
        # the gabled house's candidates and made relinking the slowest step, for the same plans.
        extra = from_probes(self.p.scene, sub, seeds, limits, per_sample=4, n_directions=48).concat(
            along_normals(sub, limits, self.p.camera, self.distance))
        self.p.add_candidates(keep_safe(self.p.scene, extra, limits, self.margin))
        self._add(todo)
        return len(todo) + len(again)

    def _seeds(self, sub: SurfaceSamples) -> np.ndarray:
        """Which of ``sub`` to probe from. Missed samples come in strips: beyond a few hundred,
        probing one per cell of half the planner's spacing finds the same views."""
        if len(sub) <= 300:
            return np.arange(len(sub))
        return thin(sub.points, sub.normals, max(self.p.samples.spacing / 2.0, sub.spacing))

    def _probe_again(self, rows: np.ndarray) -> None:
        """Samples still missed after a round of repair: the first time four times the probe
        directions, every time views a few degrees around the views they already have."""
        lim = self.p.limits
        # The check counts views with CHECK_MARGIN of range to spare around the sample's ball:
        # the farthest probe sits just inside that (the generic 0.97 of the range lies beyond it).
        top = max(((1.0 - CHECK_MARGIN) * lim.d_opt - self.ball_m - 1e-3 - lim.security)
                  / (lim.d_opt - lim.security), 0.0)
        first = np.flatnonzero(~self.dense[rows])
        if len(first):
            self.dense[rows[first]] = True
            sub = self.fine.subset(rows[first])
            extra = from_probes(self.p.scene, sub, self._seeds(sub), lim, per_sample=8, n_directions=192,
                                range_fractions=(0.35, 0.6, 0.8, top))
            self.p.add_candidates(keep_safe(self.p.scene, extra, lim, self.margin))
        sub = self.fine.subset(rows)
        # Then a few degrees around every view these samples have: their safe views may fill a
        # cone narrower than the probes' spacing.
        cam, pt, _ = self.p.pairs
        cols = self.column[rows]
        seen = np.flatnonzero(np.isin(pt, cols))
        if len(seen) > MAX_AROUND:
            seen = seen[np.linspace(0, len(seen) - 1, MAX_AROUND).astype(np.int64)]
        by_col = np.argsort(cols)  # columns come in the order samples joined, not by row
        owner = by_col[np.searchsorted(cols[by_col], pt[seen])]
        near = around_views(self.p.scene, sub, owner, self.p.cands.positions[cam[seen]], lim,
                            range_fractions=(0.5, 0.75, top))
        self.p.add_candidates(keep_safe(self.p.scene, near, lim, self.margin))

    def _add(self, todo: np.ndarray) -> None:
        self.column[todo] = len(self.p.samples) + np.arange(len(todo))
        # Judged here as the check judges them, or repair would pick views the check rejects.
        self.p.add_samples(self.fine.subset(todo), probe_shrink=CHECK_MARGIN, ball_m=self.ball_m,
                           sight_m=self.sight_m)

    def sharpen(self, chosen: np.ndarray, views: int, kinds=(OPPOSED_TERRACE,)) -> np.ndarray:
        """``add_sharp_views`` judged on the check samples of the given surface classes (default
        down-facing), not only on the planner's coarser samples; returns the extended shots.

        Under an overhang no view reaches 35 deg (the gimbal tilts up 30 deg at most), and the
        sharp views the planner's samples 1-2 m apart asked for left the strip along the edge
        seen at 43-44 deg: 72-76 % rebuilt there, against 91-97 % deeper in (ring prism).

        Parameters
        ----------
        chosen : (k,) int
            Candidate indices.
        views : int
            Sharp views per sample.
        kinds : sequence of int
            Surface classes judged.

        Returns
        -------
        (m,) int
            ``chosen`` and the shots added.
        """
        rows = np.flatnonzero(np.isin(self.fine.kind, kinds) & self.reachable)
        if len(rows) == 0 or views <= 0:
            return chosen
        sub = self.fine.subset(rows)
        cam, pt, _ = self.p.pairs_between(self.p.cands, sub)
        inc = incidence_deg(cam, pt, self.p.cands.positions, sub.points, sub.normals)
        return add_sharp_views(cam, pt, inc, len(self.p.cands), sub.area, chosen, views=views)

    @property
    def tree(self) -> cKDTree:
        """A KD-tree of the check samples' points."""
        return self._tree

    def all_views(self) -> tuple[np.ndarray, np.ndarray]:
        """(candidate, check sample) of every view the checks so far found, firm or not: what
        the evaluator would count.

        Returns
        -------
        who, pt : (m,) int
            Candidate and check sample.
        """
        who, pt, _firm = self._views
        return who, pt

    def firm_views(self) -> tuple[np.ndarray, np.ndarray]:
        """(candidate, check sample) of every view the checks so far counted.

        Returns
        -------
        who, pt : (m,) int
            Candidate and check sample.
        """
        who, pt, firm = self._views
        return who[firm], pt[firm]

    def uncovered(self, check: FineCheck, lost_path: bool = False) -> list[dict]:
        """Every missed check sample with its area and why: unreachable (the probes' reason),
        or what the candidates lack (too few views, no pair in the angle window).

        Parameters
        ----------
        check : FineCheck
            The last check.
        lost_path : bool
            The shots were dropped because no safe path reaches them.

        Returns
        -------
        list of dict
            Position, area, part and reason per missed sample.
        """
        self._add(np.flatnonzero(check.missed & (self.column < 0)))
        missed = np.flatnonzero(check.missed)
        cols = self.column[missed]
        cam, pt, _ = self.p.pairs
        inside = np.isin(pt, cols)
        cam, pt = cam[inside], pt[inside]
        local = np.searchsorted(np.sort(cols), pt)
        order = np.argsort(cols)  # local index k refers to missed[order[k]]
        n = len(cols)
        possible = np.bincount(local, minlength=n)
        rays = view_rays(cam, pt, self.p.cands.positions, self.p.samples.points)
        wide = has_pair_between(local, rays, n, self.min_triangulation_deg, None)
        matchable = has_pair_between(local, rays, n, self.min_triangulation_deg, self.max_pair_deg)
        out = []
        for k in range(n):
            s = missed[order[k]]
            if not check.reachable[s]:
                reason = check.reason[s]
            elif check.edge is not None and check.edge[s]:
                reason = EDGE_REASON
            elif possible[k] < self.min_views:
                reason = f"only {possible[k]} safe viewpoint(s) found that image it (needs {self.min_views})"
            elif not wide[k]:
                reason = f"its safe views are all within {self.min_triangulation_deg:g} deg of each other"
            elif not matchable[k]:
                reason = (f"no two of its safe views are between {self.min_triangulation_deg:g} and {self.max_pair_deg:g} deg "
                          "apart (a pair that triangulates and still matches)")
            elif lost_path:
                reason = "its viewpoints have no safe path from the start point"
            else:
                reason = "not covered by the selected shots"
            out.append({"position": self.fine.points[s].tolist(), "normal": self.fine.normals[s].tolist(),
                        "area_m2": float(self.fine.area[s]), "reachable": bool(check.reachable[s]),
                        "reason": reason})
        return out
