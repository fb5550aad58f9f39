"""The planner's check samples: a finer, independent sampling the shots are judged on as the evaluator judges a route, and the verdict on them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from coverplan.shots.surface import (
    SurfaceSamples,
    check_spacing,
    sample_surface,
)

PLANNER_CHECK_SEED = 104_729  # the evaluator samples with yet another seed


@dataclass
class FineCheck:
    """The chosen shots judged on the check samples, as the evaluator judges a route.

    Parameters
    ----------
    samples : SurfaceSamples
        The check samples.
    covered : (n,) bool
        Covered samples.
    reachable : (n,) bool
        Reachable samples.
    reason : (n,) str
        Empty when reachable, else the probes' reason.
    edge : (n,) bool, optional
        Samples beside hidden surface judged again.
    """

    samples: SurfaceSamples
    covered: np.ndarray
    reachable: np.ndarray
    reason: np.ndarray  # per sample: "" when reachable, else the probes' reason

    @property
    def coverage_pct(self) -> float:
        """The reachable surface covered, percent of its area."""
        reach = float(self.samples.area[self.reachable].sum())
        return 100.0 * float(self.samples.area[self.covered & self.reachable].sum()) / reach if reach else 0.0

    edge: np.ndarray | None = None  # per sample: imaged, but its views are cut off close by

    @property
    def missed(self) -> np.ndarray:
        """(n,) bool: the samples not covered."""
        return ~self.covered


MIN_CHECK_SAMPLES = 10_000


def planner_check_spacing(scene, plan_spacing: float) -> float:
    """0.25 m; finer for a small d_opt (half the planner's spacing) and for a small target
    (at least 10,000 samples, down to 0.1 m): on a 50 m2 shed one evaluator sample is 0.1 %.

    Parameters
    ----------
    scene : Scene
        The scene.
    plan_spacing : float
        The planner's sample spacing, metres.

    Returns
    -------
    float
        Metres.
    """
    area = sum(p.mesh.area for p in scene.targets)
    small = max(float(np.sqrt(area / MIN_CHECK_SAMPLES)), 0.1)
    return min(check_spacing(scene), check_spacing(scene, plan_spacing / 2.0), check_spacing(scene, small))


def check_samples(scene, spacing: float, surface_classes=None) -> SurfaceSamples:
    """The planner's check samples at ``spacing`` (its own seed), of some classes or all.

    Parameters
    ----------
    scene : Scene
        The scene.
    spacing : float
        Metres.
    surface_classes : sequence of str, optional
        Classes to keep.

    Returns
    -------
    SurfaceSamples
        The samples.
    """
    fine = sample_surface(scene, spacing, seed=PLANNER_CHECK_SEED)
    return fine.of_classes(surface_classes) if surface_classes else fine


def planner_check_samples(scene, route) -> SurfaceSamples:
    """The samples the planner checked ``route``'s shots on: ``route.uncovered`` lists some.

    Parameters
    ----------
    scene : Scene
        The scene.
    route : Route
        A planned route.

    Returns
    -------
    SurfaceSamples
        The samples.
    """
    spacing = route.metrics.get("check_spacing_m") or planner_check_spacing(scene, route.params["sample_spacing_m"])
    return check_samples(scene, spacing, route.params.get("surface_classes"))
