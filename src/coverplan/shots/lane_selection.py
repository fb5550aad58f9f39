"""Choosing lanes, not shots: a weighted cover over whole lanes, trimmed at their ends.

Each lane is worth the views it adds where samples still lack them (up to ``min_views`` per
sample, weighted by the sample's area) and costs its photos plus ``LANE_OVERHEAD`` photos'
worth for the turn into it; a single candidate costs ``SINGLE_COST``. A greedy cover over
both takes the best worth per cost at each step; only its lanes are kept, the singles it
counted on are left to ``select_views`` (with the lanes preset) to choose again. Then every
chosen lane loses the photos at its ends that no sample needs, so it stays one run.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

LANE_OVERHEAD = 1.0  # photos' worth of cost for entering a lane
SINGLE_COST = 3.0  # photos' worth of cost of a single shot: a stop, a turn there and back, its links


def select_lanes(vis: sp.csr_matrix, lane_of: np.ndarray, area: np.ndarray, min_views: int,
                 need: np.ndarray | None = None, positions: np.ndarray | None = None) -> np.ndarray:
    """Candidate rows of the lanes chosen, trimmed.

    Parameters
    ----------
    vis : (candidates, samples) sparse
        1 where a candidate sees a sample.
    lane_of : (candidates,) int
        The lane of each candidate, -1 for candidates that are not lane photos. A lane's
        photos are consecutive rows in flight order.
    area : (samples,) float
        The samples' areas, m2.
    min_views : int
        Views each sample needs.
    need : (samples,) int, optional
        Views each sample still needs (default ``min_views`` wherever a candidate sees it).
    positions : (candidates, 3) float, optional
        The candidates' positions: a lane whose last photo is as near its first as its photos
        are to one another is a closed ring, and is not trimmed (that would open a gap in it).

    Returns
    -------
    (k,) int
        Rows of the chosen lane photos, sorted.
    """
    vis = sp.csr_matrix(vis, dtype=np.float64)
    n_cand, n_samp = vis.shape
    seen = np.asarray((vis > 0).sum(axis=0)).ravel()
    need = np.where(seen > 0, min_views, 0) if need is None else np.asarray(need).copy()
    rows = np.flatnonzero(lane_of >= 0)
    if not len(rows):
        return np.zeros(0, dtype=np.int64)
    lanes = lane_of[rows]
    n_lanes = int(lanes.max()) + 1
    # lanes x samples: how many of a lane's photos see each sample.
    member = sp.csr_matrix((np.ones(len(rows)), (lanes, rows)), shape=(n_lanes, n_cand))
    counts = (member @ vis).tocsr()
    photos = np.bincount(lanes, minlength=n_lanes).astype(float)
    taken = np.zeros(n_lanes, dtype=bool)
    singles = np.flatnonzero(lane_of < 0)
    single_vis = vis[singles]
    while (need > 0).any():
        worth = _worth(counts, need, area)
        worth[taken] = 0.0
        ratio = worth / (photos + LANE_OVERHEAD)
        best = int(np.argmax(ratio))
        one = single_vis @ (area * (need > 0)) if len(singles) else np.zeros(1)
        pick = int(np.argmax(one))
        if worth[best] <= 0 and one[pick] <= 0:
            break
        if ratio[best] >= one[pick] / SINGLE_COST:
            taken[best] = True
            got = counts.getrow(best).toarray().ravel()
        else:  # a single does better here: counted, so that lanes are weighed against it, not taken
            got = np.zeros(n_samp)
            got[single_vis.indices[single_vis.indptr[pick]:single_vis.indptr[pick + 1]]] = 1
        need = np.maximum(need - got.astype(need.dtype), 0)
    chosen = rows[taken[lanes]]
    rings = np.zeros(n_lanes, dtype=bool) if positions is None else closed_lanes(lane_of, positions)
    trimmable = chosen[~rings[lane_of[chosen]]]
    return np.union1d(_trim_ends(vis, trimmable, lane_of, min_views, seen), chosen[rings[lane_of[chosen]]])


def closed_lanes(lane_of: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """(lanes,) bool: the lanes that close on themselves, their last photo no farther from the
    first than 1.5 times their longest step (rows of one lane are consecutive, in order)."""
    rows = np.flatnonzero(lane_of >= 0)
    lanes = lane_of[rows]
    n = int(lanes.max()) + 1 if len(rows) else 0
    out = np.zeros(n, dtype=bool)
    if not len(rows):
        return out
    step = np.linalg.norm(np.diff(positions[rows], axis=0), axis=1)
    same = lanes[1:] == lanes[:-1]
    longest = np.zeros(n)
    np.maximum.at(longest, lanes[1:][same], step[same])
    first = rows[np.r_[True, ~same]]
    last = rows[np.r_[~same, True]]
    gap = np.linalg.norm(positions[last] - positions[first], axis=1)
    count = np.bincount(lanes, minlength=n)
    out[lane_of[first]] = (count[lane_of[first]] >= 3) & (gap <= 1.5 * longest[lane_of[first]])
    return out


def _worth(counts: sp.csr_matrix, need: np.ndarray, area: np.ndarray) -> np.ndarray:
    """Per lane: the area-weighted views it adds, up to what each sample still needs."""
    capped = counts.copy()
    capped.data = np.minimum(capped.data, need[capped.indices])
    return np.asarray(capped @ area).ravel()


def _trim_ends(vis: sp.csr_matrix, chosen: np.ndarray, lane_of: np.ndarray, min_views: int,
               seen: np.ndarray) -> np.ndarray:
    """Drop end photos of chosen lanes that every sample they see can spare (it keeps
    ``min_views`` views, or all it has, without them), one end photo at a time."""
    keep = np.zeros(vis.shape[0], dtype=bool)
    keep[chosen] = True
    target = np.minimum(seen, min_views)
    have = np.asarray(vis[keep].sum(axis=0)).ravel()
    changed = True
    while changed:
        changed = False
        rows = np.flatnonzero(keep)
        if not len(rows):
            break
        lane = lane_of[rows]
        first = rows[np.r_[True, lane[1:] != lane[:-1]]]
        last = rows[np.r_[lane[1:] != lane[:-1], True]]
        for r in np.unique(np.concatenate([first, last])):
            cols = vis.indices[vis.indptr[r]:vis.indptr[r + 1]]
            if np.all(have[cols] - 1 >= target[cols]):
                keep[r] = False
                have[cols] -= 1
                changed = True
    return np.flatnonzero(keep)
