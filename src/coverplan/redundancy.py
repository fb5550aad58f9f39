"""Drop the shots a finished plan does not need.

The planner adds shots stage after stage: the cover, sharp views, links, then repair on the
check samples. Each stage adds to what the ones before chose, so by the end some early shots
give nothing the later ones do not also give (a cover shot whose samples the linking shots
around it now see as well). Once the plan is complete, each shot, latest first, is dropped
when the plan without it still has everything it had:

- every check sample it covered stays covered by the check's rule;
- every sample keeps its sharp views, up to the number asked;
- every shot keeps ``min_neighbours`` linked shots (those that had fewer lose none), and the
  linked shots fall into no more pieces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .visibility import has_pair_between


@dataclass
class SharpViews:
    """Sharp views to keep: ``views`` (candidate x sample, 1 where the view is sharp) and how
    many each sample needs."""

    views: sp.csr_matrix
    wanted: int


@dataclass
class CheckViews:
    """The views counted on the check samples (candidate ``who`` images sample ``pt`` along the
    unit ``rays``, sample to camera), which samples they cover, and the rule they are judged by."""

    who: np.ndarray
    pt: np.ndarray
    rays: np.ndarray
    covered: np.ndarray
    min_views: int
    min_tri_deg: float
    max_pair_deg: float | None


def drop_redundant(chosen: np.ndarray, views: CheckViews, sharp: list[SharpViews] = (),
                   links: np.ndarray | None = None, min_neighbours: int = 0) -> np.ndarray:
    """The shots of ``chosen`` (candidate indices, in the order picked) left once every shot
    the others make redundant is dropped, latest first. ``links``: (len(chosen),) * 2
    booleans, which chosen shots SfM will match (``shot_links``)."""
    chosen = np.asarray(chosen, dtype=np.int64)
    n = len(chosen)
    alive = np.ones(n, dtype=bool)

    order = np.argsort(chosen)
    mine = np.isin(views.who, chosen)
    pt, rays = views.pt[mine], views.rays[mine]
    row = order[np.searchsorted(chosen[order], views.who[mine])]
    by_sample = np.argsort(pt)
    pt_sorted = pt[by_sample]
    by_row = np.argsort(row, kind="stable")
    by_shot = np.split(pt[by_row], np.searchsorted(row[by_row], np.arange(1, n)))

    have = [np.asarray(s.views[chosen].sum(axis=0)).ravel() for s in sharp]
    need = [np.minimum(s.wanted, h) for s, h in zip(sharp, have)]
    sharp_rows = [s.views[chosen].tocsr() for s in sharp]

    if links is None:
        links = np.zeros((n, n), dtype=bool)
    degree = links.sum(axis=1)
    floor = np.minimum(degree, min_neighbours)
    neighbours = [np.flatnonzero(r).tolist() for r in links]

    for k in range(n - 1, -1, -1):
        # Sharp views and links first: the cheapest tests.
        if any((h[_row(m, k)] - 1 < d[_row(m, k)]).any() for h, d, m in zip(have, need, sharp_rows)):
            continue
        near = np.flatnonzero(links[k] & alive)
        if (degree[near] - 1 < floor[near]).any():
            continue
        samples = by_shot[k][views.covered[by_shot[k]]]
        if len(samples):
            lo = np.searchsorted(pt_sorted, samples, side="left")
            hi = np.searchsorted(pt_sorted, samples, side="right")
            local = np.repeat(np.arange(len(samples)), hi - lo)
            entries = by_sample[_ranges(lo, hi)]
            live = alive[row[entries]] & (row[entries] != k)
            local, entries = local[live], entries[live]
            if (np.bincount(local, minlength=len(samples)) < views.min_views).any():
                continue
            if not has_pair_between(local, rays[entries], len(samples), views.min_tri_deg,
                                    views.max_pair_deg).all():
                continue
        alive[k] = False
        if len(near) > 1 and not _joined(neighbours, alive, near):
            alive[k] = True
            continue
        degree[near] -= 1
        for h, m in zip(have, sharp_rows):
            h[_row(m, k)] -= 1
    return chosen[alive]


def _row(m: sp.csr_matrix, k: int) -> np.ndarray:
    """The columns of row ``k`` of ``m``."""
    return m.indices[m.indptr[k]:m.indptr[k + 1]]


def _joined(neighbours: list[list[int]], alive: np.ndarray, near: np.ndarray) -> bool:
    """Whether the shots ``near`` (the alive neighbours of a dropped shot) still reach each
    other through alive shots: if so, dropping it split no piece. A search from one of them
    that stops once it has met them all, mostly a few steps away."""
    want = {int(j) for j in near[1:]}
    seen = {int(near[0])}
    todo = [int(near[0])]
    while todo and want:
        for v in neighbours[todo.pop()]:
            if alive[v] and v not in seen:
                seen.add(v)
                want.discard(v)
                todo.append(v)
    return not want


def _ranges(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The concatenation of arange(lo[i], hi[i])."""
    lengths = hi - lo
    total = int(lengths.sum())
    if total == 0:
        return np.zeros(0, np.int64)
    return np.repeat(lo - np.cumsum(lengths) + lengths, lengths) + np.arange(total)
