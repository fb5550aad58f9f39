"""Local search moves on a closed tour: 2-opt reversals and Or-opt moves of short runs, vectorised in blocks."""

from __future__ import annotations

import numpy as np

EPS = 1e-9


MIN_BLOCK = 4  # rows of moves evaluated per numpy call, at first


MAX_CELLS = 16_384  # and at most (rows x tour length): big blocks of long tours waste work


def _first_move(lo: int, stop: int, moves, block: int, most: int):
    """The first row in [lo, stop) with an improving move, and that move: ``moves(lo, hi)``
    gives per row its best move's column, whether it improves and a flag. Rows are taken a
    block at a time, the block doubling up to ``most`` rows while nothing improves (late passes
    that find nothing then cost a few numpy calls, not one per row).
    Returns (row, column, flag, block)."""
    while lo < stop:
        hi = min(lo + block, stop)
        best, good, flag = moves(lo, hi)
        hit = np.flatnonzero(good)
        if len(hit):
            h = hit[0]
            return lo + int(h), int(best[h]), bool(flag[h]), block
        lo = hi
        block = min(2 * block, most)
    return None, None, None, block


def reverse_while_improving(t, moves, most: int) -> tuple[np.ndarray, bool]:
    """2-opt descent: ``moves(t, lo, hi)`` names for rows lo..hi-1 the end k of the best
    reversal of t[i..k]; the first improving one is taken and the search goes on from the next
    row, until a pass finds none.

    Parameters
    ----------
    t : (n,) int
        The tour, node 0 first; changed in place.
    moves : callable
        ``moves(t, lo, hi)`` -> (ends, improving, flags), each (hi - lo,): per row its best
        reversal's end, whether it shortens the tour, and a flag (unused here).
    most : int
        The most rows evaluated in one call.

    Returns
    -------
    t : (n,) int
        The tour.
    changed : bool
        Whether any reversal was taken.
    """
    n = len(t)
    changed = False
    improved = True
    while improved:
        improved = False
        i, block = 1, MIN_BLOCK
        while i < n - 1:
            i, k, _, block = _first_move(i, n - 1, lambda lo, hi: moves(t, lo, hi), block, most)
            if i is None:
                break
            t[i:k + 1] = t[i:k + 1][::-1].copy()
            improved = changed = True
            i, block = i + 1, MIN_BLOCK
    return t, changed


def move_runs_while_improving(t, moves, most: int, max_segment: int, last: int) -> tuple[np.ndarray, bool]:
    """Or-opt descent: for runs of 1..max_segment stops ending at tour position ``last`` at the
    latest, ``moves(t, lo, hi, length)`` names per row the tour edge k to put the run on and
    whether forwards; the first improving move is taken, until a pass finds none.

    Parameters
    ----------
    t : (n,) int
        The tour, node 0 first.
    moves : callable
        ``moves(t, lo, hi, length)`` -> (edges, improving, forwards), each (hi - lo,): per row
        (the run's first position) the tour edge to put it on, whether that shortens the tour,
        and whether the run goes in forwards.
    most : int
        The most rows evaluated in one call.
    max_segment : int
        The longest run moved.
    last : int
        The last tour position a run may end at.

    Returns
    -------
    t : (n,) int
        The tour.
    changed : bool
        Whether any run was moved.
    """
    changed = False
    improved = True
    while improved:
        improved = False
        for length in range(1, max_segment + 1):
            i, block = 1, MIN_BLOCK
            while i + length <= last:
                i, k, forward, block = _first_move(i, last - length + 1, lambda lo, hi: moves(t, lo, hi, length),
                                                   block, most)
                if i is None:
                    break
                seg = t[i:i + length]
                rest = np.concatenate([t[:i], t[i + length:]])
                pos = k if k < i - 1 else k - length  # edge k of the tour is edge pos of the rest
                piece = seg if forward else seg[::-1]
                t = np.concatenate([rest[:pos + 1], piece, rest[pos + 1:]])
                improved = changed = True
                i, block = i + 1, MIN_BLOCK
    return t, changed


def two_opt(order, dist) -> tuple[np.ndarray, bool]:
    """Reverse segments while that shortens the tour (best move per first edge, first edges
    in tour order).

    Parameters
    ----------
    order : (n,) int
        A closed tour starting at node 0.
    dist : (n, n) float
        Symmetric distances.

    Returns
    -------
    order : (n,) int
        The improved tour.
    changed : bool
        Whether any move was made.
    """
    t = np.array(order)
    n = len(t)
    cols = np.arange(n)

    def moves(t, lo, hi):
        i = np.arange(lo, hi)
        a, b = t[i - 1], t[i]
        c, d = t, np.roll(t, -1)
        delta = dist[a[:, None], c] + dist[b[:, None], d] - dist[a, b][:, None] - dist[c, d][None, :]
        delta[cols[None, :] <= i[:, None]] = np.inf
        best = np.argmin(delta, axis=1)
        good = delta[np.arange(len(i)), best] < -EPS
        return best, good, good

    return reverse_while_improving(t, moves, max(MIN_BLOCK, MAX_CELLS // n))


def or_opt(order, dist, max_segment: int = 3) -> tuple[np.ndarray, bool]:
    """Move runs of 1..max_segment stops elsewhere (either way round) while that helps.

    Parameters
    ----------
    order : (n,) int
        A closed tour starting at node 0.
    dist : (n, n) float
        Symmetric distances.
    max_segment : int
        The longest run moved.

    Returns
    -------
    order : (n,) int
        The improved tour.
    changed : bool
        Whether any move was made.
    """
    t = np.array(order)
    n = len(t)
    cols = np.arange(n)

    def moves(t, lo, hi, length):
        i = np.arange(lo, hi)
        first, last = t[i], t[i + length - 1]
        prev, nxt = t[i - 1], t[(i + length) % n]
        saved = dist[prev, first] + dist[last, nxt] - dist[prev, nxt]
        p, q = t, np.roll(t, -1)  # edge k of the tour: p[k] -> q[k]
        fwd = dist[p[None, :], first[:, None]] + dist[last[:, None], q[None, :]] - dist[p, q][None, :]
        rev = dist[p[None, :], last[:, None]] + dist[first[:, None], q[None, :]] - dist[p, q][None, :]
        both = np.minimum(fwd, rev)
        # the edges the run touches, and the one that closes the gap it leaves (putting it back)
        both[(cols[None, :] >= i[:, None] - 1) & (cols[None, :] <= i[:, None] + length - 1)] = np.inf
        best = np.argmin(both, axis=1)
        rows = np.arange(len(i))
        return best, both[rows, best] < saved - EPS, fwd[rows, best] <= rev[rows, best]

    # a run may end at the tour's last stop
    return move_runs_while_improving(t, moves, max(MIN_BLOCK, MAX_CELLS // n), max_segment, n)
