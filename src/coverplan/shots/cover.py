"""The covering problem: samples by candidates, which candidate images which sample, grown as the repair adds either."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from coverplan.shots.candidates import Candidates
from coverplan.shots.limits import ViewLimits
from coverplan.shots.surface import (
    SurfaceSamples,
)
from coverplan.shots.visibility import (
    imaging_pairs,
    seen_from_around,
    view_rays,
    visibility_matrix,
)

# The planner holds its structured candidates to a slightly stricter rule than the evaluator
# (2 % off the frustum, range and incidence) so that coverage holds between samples.
SHRINK = 0.02


PROBE = 2  # Candidates.source of reachability probes: judged without the margin


# The check counts a view only with 1 % to spare, and only if it also holds for every point
# within CHECK_BALL x its spacing of the sample, so that what it finds covered stays covered on
# samples it did not draw (the evaluator's). Without the ball, two frusta that met edge to
# edge left a strip a few cm wide between check samples 0.1 m apart: a 3 m box claimed 100 %
# and the evaluator found 99.70 % (one of its 0.25 m samples there). A quarter of the spacing
# catches that strip; half of it cost 1.6x the planning time on the gabled house.
CHECK_MARGIN = 0.01


CHECK_BALL = 0.25


@dataclass
class CoverProblem:
    """Samples x candidates and which candidate images which sample (with ranges).

    Parameters
    ----------
    scene : Scene
        The scene.
    camera : Camera
        The camera the rules are judged with.
    limits : ViewLimits
        The viewpoint rules.
    samples : SurfaceSamples
        The samples.
    cands : Candidates
        The candidates.
    pairs : tuple of (m,) arrays
        Candidate, sample and range of every imaging pair.
    ball_m : float
        From ``ball_from`` on, every view must hold within this many metres of its sample.
    ball_from : int
        The first sample judged as the check judges; -1 for none.
    sight_m : float
        And its sight from this far off the camera.
    """

    scene: object
    camera: object
    limits: ViewLimits
    samples: SurfaceSamples
    cands: Candidates
    pairs: tuple = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))  # (candidate, sample, range)
    # Samples from column ``ball_from`` on (the check's, added by repair) are judged as the
    # check judges them: every view must hold within ``ball_m`` of the sample, and its sight
    # from ``sight_m`` off the camera.
    ball_m: float = 0.0
    ball_from: int = -1
    sight_m: float = 0.0

    def pairs_between(self, cands: Candidates, samples: SurfaceSamples, progress=None,
                      probe_shrink: float = 0.0, ball_m: float = 0.0, sight_m: float = 0.0) -> tuple:
        """Imaging pairs, structured candidates with the margin, probes with ``probe_shrink``;
        with ``ball_m`` every view must hold around the sample too (``imaging_pairs``), with
        ``sight_m`` its sight from that far off the camera (``seen_from_around``).

        Parameters
        ----------
        cands : Candidates
            Cameras.
        samples : SurfaceSamples
            Samples.
        progress : Progress, optional
            Reports the stage.
        probe_shrink : float
            The frame's share cut off for probe candidates.
        ball_m : float
            Metres round the sample a view must hold.
        sight_m : float
            Metres off the camera its sight must hold.

        Returns
        -------
        cam, pt : (m,) int
            Candidate and sample of each pair.
        range : (m,) float
            Metres.
        """
        probe = cands.source == PROBE
        offset = self.scene.epsilon * 4
        out = []
        for mask, shrink in ((~probe, SHRINK), (probe, probe_shrink)):
            idx = np.flatnonzero(mask)
            if len(idx) == 0:
                continue
            c, p, r = imaging_pairs(cands.positions[idx], cands.heading_deg[idx], cands.pitch_deg[idx],
                                    self.camera, samples.points, samples.normals, self.scene.rays,
                                    max_range=self.limits.d_opt, max_incidence_deg=self.limits.max_incidence_deg,
                                    shrink=shrink, ball_m=ball_m, offset=offset, progress=progress)
            if sight_m > 0:
                seen = seen_from_around(self.scene.rays, samples.points[p] + samples.normals[p] * offset,
                                        cands.positions[idx[c]], sight_m)
                c, p, r = c[seen], p[seen], r[seen]
            out.append((idx[c], p, r))
        if not out:
            return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
        return tuple(np.concatenate(a) for a in zip(*out))

    def add_candidates(self, new: Candidates) -> None:
        """Add candidates and their imaging pairs with every sample.

        Parameters
        ----------
        new : Candidates
            The candidates.
        """
        if len(new) == 0:
            return
        if self.ball_from < 0:
            c, p, r = self.pairs_between(new, self.samples)
        else:
            head = self.pairs_between(new, self.samples.subset(np.arange(self.ball_from)))
            c, p, r = self.pairs_between(new, self.samples.subset(np.arange(self.ball_from, len(self.samples))),
                                         probe_shrink=CHECK_MARGIN, ball_m=self.ball_m, sight_m=self.sight_m)
            c, p, r = _join(head, (c, p + self.ball_from, r))
        base = len(self.cands)
        self.cands = self.cands.concat(new)
        self.pairs = _join(self.pairs, (c + base, p, r))

    def add_samples(self, new: SurfaceSamples, probe_shrink: float = 0.0, ball_m: float = 0.0,
                    sight_m: float = 0.0) -> None:
        """Add samples and their imaging pairs with every candidate.

        Parameters
        ----------
        new : SurfaceSamples
            The samples.
        probe_shrink : float
            The frame's share cut off for probe candidates.
        ball_m : float
            Metres round the sample a view must hold; the samples are then judged as the check judges.
        sight_m : float
            Metres off the camera its sight must hold.
        """
        if len(new) == 0:
            return
        c, p, r = self.pairs_between(self.cands, new, probe_shrink=probe_shrink, ball_m=ball_m, sight_m=sight_m)
        base = len(self.samples)
        if ball_m > 0 and self.ball_from < 0:
            self.ball_m, self.ball_from, self.sight_m = ball_m, base, sight_m
        self.samples = concat_samples(self.samples, new)
        self.pairs = _join(self.pairs, (c, p + base, r))

    def matrices(self) -> tuple[sp.csr_matrix, np.ndarray]:
        """The visibility matrix and, in its data order, the unit rays sample -> camera.

        Returns
        -------
        vis : scipy.sparse.csr_matrix
            Candidates by samples.
        rays : (m, 3) float
            Unit rays in ``vis.data``'s order.
        """
        cam, pt, _ = self.pairs
        vis, order = visibility_matrix(len(self.cands), len(self.samples), self.pairs)
        return vis, view_rays(cam[order], pt[order], self.cands.positions, self.samples.points)


def concat_samples(a: SurfaceSamples, b: SurfaceSamples) -> SurfaceSamples:
    """The samples of ``a`` followed by those of ``b``.

    Parameters
    ----------
    a, b : SurfaceSamples
        Samples of one scene at one spacing.

    Returns
    -------
    SurfaceSamples
        The union.
    """
    return SurfaceSamples(np.vstack([a.points, b.points]), np.vstack([a.normals, b.normals]),
                          np.concatenate([a.area, b.area]), np.concatenate([a.part, b.part]),
                          np.concatenate([a.kind, b.kind]), a.spacing, dict(a.left_out), a.flipped_normals)


def _join(a: tuple, b: tuple) -> tuple:
    return tuple(np.concatenate([x, y]) for x, y in zip(a, b))
