"""Rings of photos round a building: the walk along an offset ring and its pieces.

``smooth_walk`` places the photos of one band round one ring of the section offset by the
standoff, each facing the nearest wall: every forward step along a wall; round a convex corner
in smooth steps (the heading within ``LANE_TURN_DEG`` from one photo to the next) or, for the
corners not turned smoothly, in two steps with a photo on the corner's bisector (an edge view
of the corner); at a concave corner of the offset, pivoting in place. ``ring_lane`` turns the
walk into one closed lane of pieces cut at the corners, for the cover to take in part.
"""

from __future__ import annotations

import numpy as np
import shapely

LANE_TURN_DEG = 9.5  # a wrapped lane's heading turns at most this from one photo to the next (a smooth step: 10)
SMOOTH_SHARE = 0.5  # of a ring's convex corners turned in smooth steps (the others coarse)
COARSE_TURN_DEG = 45.0  # or, round a corner not turned smoothly, this: a photo on the corner's bisector
PIECE_TURN_DEG = 45.0  # a ring is also offered in pieces, cut at the middle of corners turning this much


def _facing(section, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``pts`` (k, 2) and the unit vectors (k, 2) from the nearest point of ``section`` to each:
    square-on to a wall beside it, towards the corner round which it turns."""
    if not len(pts):
        return pts, np.zeros((0, 2))
    near = shapely.get_coordinates(shapely.shortest_line(shapely.points(pts), section))[1::2]
    away = pts - near
    return pts, away / np.maximum(np.linalg.norm(away, axis=1, keepdims=True), 1e-12)


def smooth_walk(ring_and_kind, section, step: float, smooth_share: float = 1.0,
                smooth_deg: float = LANE_TURN_DEG, coarse_deg: float = COARSE_TURN_DEG):
    """Photos round a closed ring, no further apart than ``step`` along a wall and facing the
    nearest point of ``section``: round ``smooth_share`` of the corners (spread evenly) in steps
    of at most ``smooth_deg`` (smooth steps), round the others in steps of ``coarse_deg`` (a
    photo on the corner's bisector between the walls' last and first); where the facing jumps
    (the offset's concave corners) the photos pivot in place.

    Parameters
    ----------
    ring_and_kind : tuple
        The offset ring, (m, 2) float, and its corners' kinds.
    section : shapely geometry
        The target's section the photos face.
    step : float
        Metres between photos along a wall.
    smooth_share : float
        The share of corners rounded smoothly.
    smooth_deg : float
        The largest heading step round a smooth corner.
    coarse_deg : float
        The heading step round the others.

    Returns
    -------
    xy : (k, 2) float
        The photos in walking order.
    away : (k, 2) float
        Unit vectors from the section towards each photo (it looks along the opposite).
    """
    coords, _exterior = ring_and_kind
    ring = shapely.LinearRing(coords)
    length = ring.length
    if length < 1e-9:
        return np.zeros((0, 2)), np.zeros((0, 2))
    m = max(int(np.ceil(length / min(0.05 * step, 0.2))), 16)
    s = np.arange(m + 1) * length / m
    pts = shapely.get_coordinates(shapely.line_interpolate_point(ring, s))
    _, away = _facing(section, pts)
    angle = np.unwrap(np.arctan2(away[:, 1], away[:, 0]))
    turn = np.abs(np.diff(angle))
    bending = turn > 1e-4
    # Corners: runs of bending steps; each turned smooth or coarse.
    edges = np.diff(np.r_[0, bending.astype(np.int8), 0])
    corner = np.cumsum(edges[:-1] == 1) - 1  # the corner of each bending step, from 0
    n_corners = int(np.count_nonzero(edges == 1))
    # smooth_share of the corners, spread evenly: corner c is smooth where c * share passes a whole number.
    count = np.floor(np.arange(n_corners + 1) * smooth_share + 1e-9)
    smooth = np.r_[np.diff(count) > 0, True]  # (the last entry for steps that bend at no corner)
    limit = np.where(bending & ~smooth[np.where(corner >= 0, corner, n_corners)], np.radians(coarse_deg),
                     np.radians(smooth_deg))
    # Progress: a step's worth of length or of turn, whichever is more, so both stay in bounds;
    # round a coarse corner, the turn alone. Each wall and each corner is stretched to a whole
    # number of steps, so that photos fall on both ends of every corner (and a coarse corner's
    # middle photo on its bisector).
    along = np.where(limit > np.radians(smooth_deg), 0.0, length / m / step)
    part = np.maximum(along, turn / limit)
    run = np.cumsum(np.r_[0, bending[1:] != bending[:-1]])
    total = np.bincount(run, weights=part)
    part = part * (np.ceil(total - 1e-9) / np.maximum(total, 1e-12))[run]
    prog = np.r_[0.0, np.cumsum(part)]
    n = max(int(round(prog[-1])), 3)
    want = np.arange(n) * prog[-1] / n
    k = np.clip(np.searchsorted(prog, want, side="right") - 1, 0, m - 1)
    f = (want - prog[k]) / np.maximum(prog[k + 1] - prog[k], 1e-12)
    xy = pts[k] + f[:, None] * (pts[k + 1] - pts[k])
    a = angle[k] + f * (angle[k + 1] - angle[k])
    return xy, np.column_stack([np.cos(a), np.sin(a)])


def ring_lane(xy: np.ndarray, away: np.ndarray):
    """A closed ring's photos (``smooth_walk``) as one lane of pieces: cut at the middle of every
    convex corner that turns by ``PIECE_TURN_DEG`` or more (a wall or a run of walls between two
    such corners a piece), so that the cover can take a part of a ring where the rest sees
    nothing new. The photos start at a cut and end with the first photo again.

    Parameters
    ----------
    xy : (k, 2) float
        Photos in walking order.
    away : (k, 2) float
        Unit vectors from the section towards each photo.

    Returns
    -------
    xy, away : (k + 1, 2) float
    pieces : (p, 3) int
        As ``Lanes.pieces``, lane 0.
    closed : bool
    """
    n = len(xy)
    if n < 3:
        return xy, away, np.array([[0, 0, n]]), False
    a = np.arctan2(away[:, 1], away[:, 0])
    turn = (np.roll(a, -1) - a + np.pi) % (2 * np.pi) - np.pi  # photo k to k + 1
    bend = (np.sign(turn) == np.sign(turn.sum())) & (np.abs(turn) > np.radians(0.5))  # round a convex corner
    cuts = np.zeros(0, dtype=np.int64)
    if bend.any() and not bend.all():
        # Steps rolled to start on a straight one, so no run of bending steps wraps round the end.
        shift = int(np.flatnonzero(~bend)[0])
        bend, size = np.roll(bend, -shift), np.abs(np.roll(turn, -shift))
        edges = np.diff(np.r_[0, bend.astype(np.int8), 0])
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        within = np.cumsum(np.where(bend, size, 0.0))
        before = np.r_[0.0, within][starts]
        totals = within[ends - 1] - before
        big = np.degrees(totals) >= PIECE_TURN_DEG
        # Cut after the step where the corner's turn passes its half.
        cuts = np.sort((np.searchsorted(within, before[big] + 0.5 * totals[big]) + 1 + shift) % n)
    order = np.r_[np.roll(np.arange(n), -(cuts[0] if len(cuts) else 0)), 0]
    order[-1] = order[0]
    bounds = np.r_[cuts - (cuts[0] if len(cuts) else 0), n] if len(cuts) >= 2 else np.array([0, n])
    pieces = np.column_stack([np.zeros(len(bounds) - 1, dtype=np.int64), bounds[:-1], bounds[1:] + 1])
    return xy[order], away[order], pieces, True
