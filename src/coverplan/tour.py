"""Order the shots: a closed tour from the start point (index 0) through every shot and back.

Nearest neighbour, then 2-opt and Or-opt moves until neither improves, each move's gains
evaluated for all positions at once with numpy. Deterministic: the same matrix gives the
same tour. (OR-Tools' routing solver was measured first: 8.6 s for a 500-stop tour with
plain descent, and time-limited guided local search gives run-to-run different routes.)
"""

from __future__ import annotations

import numpy as np

_EPS = 1e-9


def tour_length(order, dist) -> float:
    order = np.asarray(order)
    return float(dist[order, np.roll(order, -1)].sum())


def nearest_neighbour(dist) -> np.ndarray:
    n = len(dist)
    order = [0]
    free = np.ones(n, dtype=bool)
    free[0] = False
    for _ in range(n - 1):
        row = np.where(free, dist[order[-1]], np.inf)
        k = int(np.argmin(row))
        order.append(k)
        free[k] = False
    return np.array(order)


def two_opt(order, dist) -> tuple[np.ndarray, bool]:
    """Reverse segments while that shortens the tour (best move per first edge)."""
    t = np.array(order)
    n = len(t)
    changed = False
    improved = True
    while improved:
        improved = False
        for i in range(1, n - 1):
            j = np.arange(i + 1, n)
            a, b = t[i - 1], t[i]
            c, d = t[j], t[(j + 1) % n]
            delta = dist[a, c] + dist[b, d] - dist[a, b] - dist[c, d]
            k = int(np.argmin(delta))
            if delta[k] < -_EPS:
                t[i:j[k] + 1] = t[i:j[k] + 1][::-1].copy()
                improved = changed = True
    return t, changed


def or_opt(order, dist, max_segment: int = 3) -> tuple[np.ndarray, bool]:
    """Move runs of 1..max_segment stops elsewhere (either way round) while that helps."""
    t = np.array(order)
    n = len(t)
    changed = False
    improved = True
    while improved:
        improved = False
        for length in range(1, max_segment + 1):
            i = 1
            while i + length <= n:
                seg = t[i:i + length]
                prev, nxt = t[i - 1], t[(i + length) % n]
                saved = dist[prev, seg[0]] + dist[seg[-1], nxt] - dist[prev, nxt]
                rest = np.concatenate([t[:i], t[i + length:]])
                p, q = rest, np.concatenate([rest[1:], rest[:1]])  # np.roll(rest, -1), 5x cheaper
                fwd = dist[p, seg[0]] + dist[seg[-1], q] - dist[p, q]
                rev = dist[p, seg[-1]] + dist[seg[0], q] - dist[p, q]
                both = np.minimum(fwd, rev)
                both[i - 1] = np.inf  # putting it back where it was
                pos = int(np.argmin(both))
                if both[pos] < saved - _EPS:
                    piece = seg if fwd[pos] <= rev[pos] else seg[::-1]
                    t = np.concatenate([rest[:pos + 1], piece, rest[pos + 1:]])
                    improved = changed = True
                i += 1
    return t, changed


def solve_tour(dist) -> np.ndarray:
    """A short closed tour over all nodes of the symmetric matrix ``dist``, starting at 0."""
    dist = np.asarray(dist, dtype=float)
    n = len(dist)
    if n <= 3:
        return np.arange(n)
    order = nearest_neighbour(dist)
    while True:
        order, a = two_opt(order, dist)
        order, b = or_opt(order, dist)
        if not (a or b):
            return order
