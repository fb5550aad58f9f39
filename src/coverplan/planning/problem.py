"""The problem the shots are chosen on: samples, reachability, candidates (lanes first) and visibility."""

from __future__ import annotations

from concurrent.futures import Executor, Future
from dataclasses import dataclass

import numpy as np

from coverplan.errors import PlanningError
from coverplan.flight.lattice import build_lattice, lattice_box
from coverplan.planning.setup import Setup, plan_lattice_spacing
from coverplan.progress import Progress
from coverplan.shots.across_lanes import across_lanes, recess_lanes
from coverplan.shots.candidates import Candidates, along_normals, facade_rings, keep_safe, under_overhangs
from coverplan.shots.check_samples import check_samples, planner_check_spacing
from coverplan.shots.cover import CoverProblem
from coverplan.shots.edge_views import edge_views, required_edge_views
from coverplan.shots.framing import (
    CLOSE_SHARE,
    frame_fill,
    short_of_framing,
    view_fill,
)
from coverplan.shots.lanes import NEAR_LANE_SHARES, Lanes, courtyard_lanes, facade_lanes, safe_lanes
from coverplan.shots.probe_views import from_probes
from coverplan.shots.reachability import (
    Reachability,
    reachability,
)
from coverplan.shots.reconstructability import candidate_links
from coverplan.shots.roof_lanes import roof_lanes
from coverplan.shots.sharpness import incidence_deg
from coverplan.shots.surface import SurfaceSamples, sample_surface
from coverplan.shots.visibility import has_pair_between, view_rays


@dataclass(frozen=True)
class Problem:
    """Samples, where they can be seen from, the candidates and which candidate sees which sample.

    The futures are work started on the other core for later stages: the check samples, the
    candidates' link graph and the flight graph's lattice (None when it depends on the shots).

    Parameters
    ----------
    samples : SurfaceSamples
        The planner's samples of the target surface.
    reach : Reachability
        Where each sample can be seen from.
    cover : CoverProblem
        The candidates and their visibility.
    vis : scipy.sparse.csr_matrix
        Candidates by samples: which candidate sees which sample.
    rays : (m, 3) float
        The unit view ray of each visible pair.
    fine_job : Future
        The check samples, made on the other core.
    links_job : Future or None
        The candidates' link graph.
    lattice_job : Future or None
        The flight graph's lattice.
    fixed : (f,) int
        Candidates that are photos already taken.
    required : (r,) int
        Candidates every plan keeps (the edge views).
    fill : (c, p) float
        ``frame_fill`` of the candidates when framed views are asked, else no columns.
    lanes : Lanes
        The candidate lanes.
    """

    samples: SurfaceSamples
    reach: Reachability
    cover: CoverProblem
    vis: object  # (candidates, samples) sparse visibility
    rays: np.ndarray
    fine_job: Future
    links_job: Future | None
    lattice_job: Future | None
    fixed: np.ndarray  # (k,) candidate indices of photos already taken (settings.existing)
    required: np.ndarray  # (k,) candidate indices every plan takes: the edge views (settings.edge_views)
    fill: np.ndarray  # (candidates, N_BINS) frame_fill of the candidates (framing.py); no columns without framed views
    lanes: Lanes  # the lane photos: the first len(lanes) candidates (settings.selection "lanes")

    def lane_of(self, n: int) -> np.ndarray:
        """(n,) int: the lane of each of the first ``n`` candidates, -1 for those not in a lane.

        Parameters
        ----------
        n : int
            How many candidates.

        Returns
        -------
        (n,) int
            The lane index, -1 outside a lane.
        """
        out = np.full(n, -1, dtype=np.int64)
        out[:len(self.lanes)] = self.lanes.lane
        return out

    @property
    def kept(self) -> np.ndarray:
        """(k,) candidate indices every plan keeps: the photos already taken and the required ones."""
        return np.union1d(self.fixed, self.required)


def build_problem(scene, setup: Setup, progress: Progress, pool: Executor) -> Problem:
    """Surface samples, reachability, candidate viewpoints and the visibility matrix.

    Parameters
    ----------
    scene : Scene
        The scene planned.
    setup : Setup
        The resolved settings.
    progress : Progress
        Reports the stages.
    pool : Executor
        Runs the check samples, the link graph and the lattice beside this thread.

    Returns
    -------
    Problem
        The samples, candidates and visibility.
    """
    settings, limits, camera = setup.asked, setup.limits, setup.camera
    classes = settings.surface_classes
    # The check samples depend on the target alone: drawn on another core meanwhile (Embree
    # and HiGHS release the GIL), they are ready when the repair needs them.
    fine_job = pool.submit(check_samples, scene, planner_check_spacing(scene, setup.spacing), classes)
    with progress.stage("surface samples"):
        samples = sample_surface(scene, setup.spacing)
        if classes:
            samples = samples.of_classes(classes)
            if len(samples) == 0:
                raise PlanningError(f"the target has no {' or '.join(classes)} surface")
    with progress.stage("reachability"):
        reach = reachability(scene, samples, limits)
    lanes = Lanes.empty()
    if settings.selection == "lanes":
        with progress.stage("lanes"):
            nearest = 1.2 * (limits.security + setup.extra_clearance)
            lanes = Lanes.empty()
            # Nearer in: courtyards and recesses the standoff does not fit.
            for distance in sorted({setup.standoff} | {max(share * setup.standoff, nearest) for share in NEAR_LANE_SHARES},
                                   reverse=True):
                lanes = lanes.concat(facade_lanes(scene, camera, limits, distance, settings.forward_overlap,
                                                  settings.side_overlap))
            lanes = lanes.concat(courtyard_lanes(scene, camera, limits, 1.1 * nearest, setup.standoff,
                                                 settings.forward_overlap, settings.side_overlap))
            lanes = lanes.concat(across_lanes(scene, camera, limits, setup.standoff, nearest, settings.forward_overlap))
            lanes = lanes.concat(recess_lanes(scene, camera, limits, nearest, settings.forward_overlap,
                                              settings.side_overlap))
            lanes = lanes.concat(roof_lanes(scene, samples, camera, limits, setup.standoff, settings.forward_overlap,
                                            settings.side_overlap))
            lanes = safe_lanes(scene, lanes, limits, setup.extra_clearance)
    with progress.stage("candidate viewpoints"):
        cands = facade_rings(scene, camera, limits, setup.standoff, setup.spacing,
                             view_tilts=settings.view_tilts).concat(
            along_normals(samples, limits, camera, setup.standoff,
                          n_tilts=4 if settings.view_tilts == "varied" else 0))
        if settings.edge_views:
            cands = cands.concat(edge_views(samples, limits, camera, setup.standoff))
        cands = keep_safe(scene, cands.concat(under_overhangs(samples, limits, camera, setup.extra_clearance)),
                          limits, setup.extra_clearance)
        cands = lanes.cands.concat(cands)  # lane photos first: Problem.lane_of

    cover = CoverProblem(scene, camera, limits, samples, cands)
    with progress.stage("visibility matrix", total=len(cands), unit="cam") as update:
        cover.pairs = cover.pairs_between(cands, samples, progress=update)
        # Samples the structured candidates leave short get candidates from their own probes
        # (judged without the margin: they serve samples only grazing views reach).
        needy = _short_samples(cover.pairs, cands.positions, samples, settings.min_views, setup.min_triangulation_deg,
                               setup.max_pair_deg) & reach.reachable
        cover.add_candidates(keep_safe(scene, from_probes(scene, samples, np.flatnonzero(needy), limits),
                                       limits, setup.extra_clearance))
    framing = setup.match is not None and setup.match.framed_views > 0
    fill = np.zeros((len(cover.cands), 0), dtype=np.float32)  # frame_fill's, when framed views are asked
    if framing:
        with progress.stage("framing"):
            fill = fill_of(scene, cover.cands, setup)
            # Faces that no candidate at the standoff frames well (towers, chimneys, spires) get
            # candidates closer in along their normals.
            cam, pt, _ = cover.pairs
            inc = incidence_deg(cam, pt, cover.cands.positions, samples.points, samples.normals)
            short = short_of_framing(cam, pt, view_fill(fill, cam, pt, samples.normals), inc, len(samples),
                                     setup.match.framed_views) & reach.reachable
            if short.any():
                near = max(setup.standoff * CLOSE_SHARE, (limits.security + setup.extra_clearance) * 1.05)
                close = keep_safe(scene, along_normals(samples.subset(short), limits, camera, near), limits,
                                  setup.extra_clearance)
                cover.add_candidates(close)
                fill = np.vstack([fill, fill_of(scene, close, setup)])
    fixed = np.zeros(0, dtype=np.int64)
    if settings.existing is not None:  # taken, not flown: no safety or gimbal test
        with progress.stage("photos already taken"):
            base = len(cover.cands)
            existing = settings.existing.candidates()
            cover.add_candidates(existing)
            fill = np.vstack([fill, fill_of(scene, existing, setup) if framing else
                              np.zeros((len(existing), 0), dtype=np.float32)])
            fixed = np.arange(base, len(cover.cands))
    vis, rays = cover.matrices()
    reach = reach.with_witnesses(np.bincount(cover.pairs[1], minlength=len(samples)) > 0)
    # The candidates' link graph depends on vis alone: built on the other core while HiGHS
    # (which releases the GIL) solves the selection's LP, it is ready when linking starts.
    links_job = pool.submit(candidate_links, vis, cover.cands.positions, samples.points,
                            setup.match, normals=samples.normals) if setup.match is not None else None
    # So is the flight graph's lattice when its spacing cannot depend on which shots are chosen
    # (build_flight_graph checks that the shots ask for this very lattice, or builds another).
    h = plan_lattice_spacing(scene, cover.cands.positions, setup)
    lattice_job = None
    if h == plan_lattice_spacing(scene, np.zeros((0, 3)), setup):
        lattice_job = pool.submit(build_lattice, scene, limits, lattice_box(scene, limits, np.zeros((0, 3)), h),
                                  setup.start, margin=setup.extra_clearance, spacing=h)
    required = required_edge_views(cover.cands, camera, setup.standoff, vis.getnnz(axis=1),
                                   taken=cover.cands.subset(fixed)) \
        if settings.edge_views else np.zeros(0, dtype=np.int64)
    return Problem(samples, reach, cover, vis, rays, fine_job, links_job, lattice_job, fixed, required, fill, lanes)


def fill_of(scene, cands: Candidates, setup: Setup) -> np.ndarray:
    """``frame_fill`` of candidates, framed by the camera asked for (not the one narrowed by the
    pose margin: exposure and features come from the whole frame).

    Parameters
    ----------
    scene : Scene
        The scene.
    cands : Candidates
        The candidate poses.
    setup : Setup
        Gives the camera asked for.

    Returns
    -------
    (n, p) float
        The share of each frame region the scene fills.
    """
    return frame_fill(scene, cands.positions, cands.heading_deg, cands.pitch_deg, setup.asked_camera)


def _short_samples(pairs, positions, samples, min_views, min_triangulation_deg, max_pair_deg=None) -> np.ndarray:
    cam, pt, _ = pairs
    views = np.bincount(pt, minlength=len(samples))
    rays = view_rays(cam, pt, positions, samples.points)
    short = (views < min_views + 1) | ~has_pair_between(pt, rays, len(samples), min_triangulation_deg * 2, None)
    if max_pair_deg is None:
        return short
    return short | ~has_pair_between(pt, rays, len(samples), min_triangulation_deg, max_pair_deg)
