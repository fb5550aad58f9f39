"""The photos a route's coverage counts, where the drone takes them, and the links SfM should find between them."""

from __future__ import annotations

import numpy as np

from coverplan.flight.route import Route
from coverplan.shots.link_graph import graph_summary
from coverplan.shots.reconstructability import MatchRule, shot_links
from coverplan.shots.surface import (
    SurfaceSamples,
)


def photo_poses(route: Route) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions (k, 3), headings and pitches (k,) of every photo the route's coverage counts:
    its own, where the drone takes them (flown through, off the planned point), then the photos
    already taken that it was planned around (``params.existing_photos``).

    Parameters
    ----------
    route : Route
        The route judged.

    Returns
    -------
    positions : (k, 3) float
        Camera centres in the local frame, metres.
    headings, pitches : (k,) float
        Degrees (heading clockwise from north, pitch negative down).
    """
    rows = route.shots
    pos, heading, pitch = route.flown_positions()[rows], route.heading_deg[rows], route.pitch_deg[rows]
    taken = route.params.get("existing_photos") or {}
    if taken.get("positions"):
        pos = np.vstack([pos, np.asarray(taken["positions"], dtype=float).reshape(-1, 3)])
        heading = np.concatenate([heading, np.asarray(taken["heading_deg"], dtype=float)])
        pitch = np.concatenate([pitch, np.asarray(taken["pitch_deg"], dtype=float)])
    return pos, heading, pitch


def match_rule(route: Route) -> MatchRule:
    """The rule for linking photos that a route declares (the defaults when it declares none).

    Parameters
    ----------
    route : Route
        The route whose params may set ``max_pair_deg``, ``min_overlap`` and the rest.

    Returns
    -------
    MatchRule
        The rule the evaluator links photos by.
    """
    d = MatchRule()
    return MatchRule(float(route.params.get("max_pair_deg") or d.max_pair_deg),
                     float(route.params.get("min_overlap") or d.min_overlap),
                     int(route.params.get("min_neighbours") or d.min_neighbours),
                     link_test=str(route.params.get("link_test") or d.link_test))


def shot_graph(route: Route, samples: SurfaceSamples, pairs) -> dict:
    """Which photos SfM should match (reconstructability.py), measured on these samples.

    Parameters
    ----------
    route : Route
        The route judged.
    samples : SurfaceSamples
        The evaluator's samples of the target surface.
    pairs : tuple of (m,) int arrays
        Photo index, sample index and a third array for every visible (photo, sample) pair.

    Returns
    -------
    dict
        The link graph's summary (components, weak photos) with the rule it used.
    """
    import scipy.sparse as sp

    cam, pt, _ = pairs
    n = len(photo_poses(route)[0])
    vis = sp.csr_matrix((np.ones(len(cam)), (cam, pt)), shape=(n, len(samples)))
    rule = match_rule(route)
    summary = graph_summary(shot_links(vis, photo_poses(route)[0], samples.points, rule, normals=samples.normals), rule)
    summary.update({"max_pair_deg": rule.max_pair_deg, "min_overlap": rule.min_overlap,
                    "min_neighbours": rule.min_neighbours, "link_test": rule.link_test})
    return summary
