"""The evaluator's verdict on a route: its metrics, the uncovered samples and the figures' data."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from coverplan.evaluation.table import format_metrics
from coverplan.flight.route import Route
from coverplan.shots.surface import (
    SurfaceSamples,
)


@dataclass
class Evaluation:
    """Per-sample results and the metrics of docs/design.md for one route.

    Parameters
    ----------
    route : Route
        The route judged.
    samples : SurfaceSamples
        The evaluator's own surface samples (n of them), never the planner's.
    views : (n,) int
        Valid views of each sample.
    widest_deg : (n,) float
        The widest angle between two of its valid views.
    covered, reachable : (n,) bool
        Covered by the rule; imageable from some safe position at all.
    reasons : list of str
        Why each unreachable sample cannot be imaged.
    pairs : tuple of three (m,) arrays
        Photo index, sample index and range (m) of every valid view.
    segment_clearance : (n_waypoints - 1,) float
        Each path segment's least distance to any mesh or the ground (m).
    segment_mesh : (n_waypoints - 1,) int
        The mesh that distance is to.
    waypoint_inside : (n_waypoints,) int
        The mesh a waypoint lies inside, -1 for none.
    metrics : dict
        Coverage, clearance, altitudes, zones, links, per class (``table()`` prints them).
    """

    route: Route
    samples: SurfaceSamples
    views: np.ndarray
    widest_deg: np.ndarray
    covered: np.ndarray
    reachable: np.ndarray
    reasons: list
    pairs: tuple
    segment_clearance: np.ndarray
    segment_mesh: np.ndarray
    waypoint_inside: np.ndarray
    metrics: dict = field(default_factory=dict)

    @property
    def safe(self) -> bool:
        """True when no part of the flight comes closer than the security distance to anything."""
        return bool(self.metrics["safe"])

    @property
    def coverage_pct(self) -> float:
        """The share of the target surface covered, in percent."""
        return float(self.metrics["coverage_pct"])

    def table(self) -> str:
        return format_metrics(self.metrics)
