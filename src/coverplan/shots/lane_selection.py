"""Choosing lanes, not shots: a weighted cover over pieces of lanes, trimmed at their ends.

Each piece of a lane (``Lanes.pieces``: a wall or a run of walls of a ring, a strip of a roof
grid) is worth the views its photos not yet taken add where samples still lack them (up to
``min_views`` per sample, weighted by the sample's area) and costs those photos plus
``LANE_OVERHEAD`` photos' worth for the turn into it, nothing when it continues a piece already
taken. A single candidate costs ``SINGLE_COST``: singles are counted where they do better (so
that no lane is flown for what one photo gives) but not taken; ``select_views`` chooses them
again with the lanes preset. The pieces taken join into runs; a gap of ``MAX_RING_GAP`` photos or
fewer in a ring is filled (flown through, it costs its photos and saves the turns off the ring
and back); each run then loses the photos at its ends that no sample needs, so it stays one
run, and a ring taken whole is flown once round.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from coverplan.shots.lanes import Lanes

LANE_OVERHEAD = 1.0  # photos' worth of cost for entering a lane
SINGLE_COST = 12.0  # photos' worth of a single shot: a stop, a turn there and back, its links, two steps not smooth
MAX_RING_GAP = 6  # photos: a gap this short in a ring taken in part is flown through, saving the turns off and back


def select_lanes(vis: sp.csr_matrix, lanes: Lanes, area: np.ndarray, min_views: int,
                 need: np.ndarray | None = None) -> np.ndarray:
    """Candidate rows of the lane photos chosen, trimmed.

    Parameters
    ----------
    vis : (candidates, samples) sparse
        1 where a candidate sees a sample; the first ``len(lanes)`` candidates are the lanes'
        photos, the rest single candidates.
    lanes : Lanes
        The lanes and their pieces.
    area : (samples,) float
        The samples' areas, m2.
    min_views : int
        Views each sample needs.
    need : (samples,) int, optional
        Views each sample still needs (default ``min_views`` wherever a candidate sees it).

    Returns
    -------
    (k,) int
        Rows of the chosen lane photos, sorted.
    """
    vis = sp.csr_matrix(vis, dtype=np.float64)
    n_lane = len(lanes)
    if n_lane == 0 or len(lanes.pieces) == 0:
        return np.zeros(0, dtype=np.int64)
    seen = np.asarray((vis > 0).sum(axis=0)).ravel()
    need = np.where(seen > 0, min_views, 0) if need is None else np.asarray(need).copy()
    first, stop = lanes.pieces[:, 1], lanes.pieces[:, 2]
    sizes = stop - first
    member = sp.csr_matrix((np.ones(int(sizes.sum())), (np.repeat(np.arange(len(sizes)), sizes),
                                                        np.concatenate([np.arange(a, b) for a, b in zip(first, stop)]))),
                           shape=(len(sizes), n_lane))
    lane_vis = vis[:n_lane]
    single_vis = vis[n_lane:]
    taken = np.zeros(n_lane, dtype=bool)
    while (need > 0).any():
        fresh = member @ sp.diags((~taken).astype(float))
        counts = (fresh @ lane_vis).tocsr()
        photos = np.asarray(fresh.sum(axis=1)).ravel()
        worth = _worth(counts, need, area)
        continues = taken[first] | taken[stop - 1]
        ratio = worth / np.maximum(photos + np.where(continues, 0.0, LANE_OVERHEAD), 1e-9)
        best = int(np.argmax(ratio))
        one = single_vis @ (area * (need > 0)) if single_vis.shape[0] else np.zeros(1)
        pick = int(np.argmax(one))
        if worth[best] <= 0 and one[pick] <= 0:
            break
        if ratio[best] >= one[pick] / SINGLE_COST:
            taken[first[best]:stop[best]] = True
            got = counts.getrow(best).toarray().ravel()
        else:  # a single does better here: counted, so that lanes are weighed against it, not taken
            got = np.zeros(len(need))
            got[single_vis.indices[single_vis.indptr[pick]:single_vis.indptr[pick + 1]]] = 1
        need = np.maximum(need - got.astype(need.dtype), 0)
    taken = _close_rings(lanes, _fill_rings(lanes, taken))
    whole = np.zeros(lanes.count, dtype=bool)
    rows_of = np.bincount(lanes.lane, minlength=lanes.count)
    whole[:] = np.bincount(lanes.lane[taken], minlength=lanes.count) == rows_of - lanes.closed
    keep_whole = taken & whole[lanes.lane] & lanes.closed[lanes.lane]
    # Round a ring taken in part, its last photo and its first are one run: neither is an end.
    joint = np.zeros(n_lane, dtype=bool)
    joint[_ring_joints(lanes, taken).ravel()] = True
    return np.union1d(_trim_ends(lane_vis, np.flatnonzero(taken & ~keep_whole), lanes.lane, min_views, seen, joint),
                      np.flatnonzero(keep_whole))


def _fill_rings(lanes: Lanes, taken: np.ndarray, max_gap: int = MAX_RING_GAP) -> np.ndarray:
    """``taken`` with the gaps of ``max_gap`` photos or fewer in every ring taken in part
    filled."""
    taken = taken.copy()
    for lane in np.flatnonzero(lanes.closed):
        rows = np.flatnonzero(lanes.lane == lane)[:-1]  # without the repeated first photo
        got = taken[rows] | (taken[rows[-1] + 1] & (np.arange(len(rows)) == 0))
        if not got.any() or got.all():
            continue
        shift = int(np.flatnonzero(got)[0])
        ring = np.roll(got, -shift)
        edges = np.diff(np.r_[0, (~ring).astype(np.int8), 0])
        for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
            if b - a <= max_gap:
                taken[rows[(np.arange(a, b) + shift) % len(rows)]] = True
    return taken


def _close_rings(lanes: Lanes, taken: np.ndarray) -> np.ndarray:
    """``taken`` without the repeated first photo of every ring whose first photo is taken."""
    taken = taken.copy()
    rows = np.flatnonzero(lanes.closed[lanes.lane])
    if not len(rows):
        return taken
    lane = lanes.lane[rows]
    first = rows[np.r_[True, lane[1:] != lane[:-1]]]
    last = rows[np.r_[lane[1:] != lane[:-1], True]]
    both = taken[first] | taken[last]
    taken[first[both]] = True
    taken[last] = False
    return taken


def ring_pairs(lanes: Lanes, rows: np.ndarray) -> np.ndarray:
    """(k, 2) int: pairs of ``rows`` (lane photos) flown one after the other: consecutive rows of
    one lane, and round a ring, its last photo before the repeated first and the first.

    Parameters
    ----------
    lanes : Lanes
        The lanes.
    rows : (k,) int
        Chosen lane photos.

    Returns
    -------
    (m, 2) int
        Pairs of rows.
    """
    chosen = np.zeros(len(lanes), dtype=bool)
    chosen[np.asarray(rows, dtype=np.int64)] = True
    pairs = lanes.neighbours()
    pairs = pairs[chosen[pairs[:, 0]] & chosen[pairs[:, 1]]]
    return np.vstack([pairs, _ring_joints(lanes, chosen)])


def _ring_joints(lanes: Lanes, chosen: np.ndarray) -> np.ndarray:
    """(k, 2) int: per ring whose repeated first photo is not ``chosen`` (bool) but whose first
    and last photos are: those two, which the drone flies one after the other."""
    closed = np.flatnonzero(lanes.closed)
    first = np.searchsorted(lanes.lane, closed)
    last = np.searchsorted(lanes.lane, closed, side="right") - 1  # the repeated first photo
    ok = chosen[first] & chosen[last - 1] & ~chosen[last]
    return np.column_stack([last[ok] - 1, first[ok]]).astype(np.int64)


def _worth(counts: sp.csr_matrix, need: np.ndarray, area: np.ndarray) -> np.ndarray:
    """Per piece: the area-weighted views it adds, up to what each sample still needs."""
    capped = counts.copy()
    capped.data = np.minimum(capped.data, need[capped.indices])
    return np.asarray(capped @ area).ravel()


def _trim_ends(vis: sp.csr_matrix, chosen: np.ndarray, lane_of: np.ndarray, min_views: int,
               seen: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """Drop end photos of the chosen runs that every sample they see can spare (it keeps
    ``min_views`` views, or all it has, without them), one end photo at a time; never the
    ``fixed`` rows (bool)."""
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
        new_run = np.r_[True, (np.diff(rows) != 1) | (np.diff(lane_of[rows]) != 0)]
        ends = np.unique(np.concatenate([rows[new_run], rows[np.r_[new_run[1:], True]]]))
        for r in ends[~fixed[ends]]:
            cols = vis.indices[vis.indptr[r]:vis.indptr[r + 1]]
            if np.all(have[cols] - 1 >= target[cols]):
                keep[r] = False
                have[cols] -= 1
                changed = True
    return np.flatnonzero(keep)
