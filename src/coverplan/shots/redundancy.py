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

``prune_redundant`` does the same for the covering alone, within view selection.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from coverplan.runs import run_offsets
from coverplan.shots.link_graph import depth_first
from coverplan.shots.visibility import has_pair_between

# Views to spare on every check sample a shot dropped by the final trim covered. With none,
# the gabled house's plan fell from 47 to 39 photos and one field draw in three rebuilt its
# north face at 87 % (benchmarks/results/experiment_prune_after_bracing_gabled.json).
TRIM_SPARE_VIEWS = 1


@dataclass
class SharpViews:
    """Sharp views to keep: ``views`` (candidate x sample, 1 where the view is sharp) and how
    many each sample needs.

    Parameters
    ----------
    views : scipy.sparse.csr_matrix
        Candidates by samples, 1 where the view is sharp.
    wanted : int
        Sharp views each sample needs.
    """

    views: sp.csr_matrix
    wanted: int


@dataclass
class CheckViews:
    """The views counted on the check samples (candidate ``who`` images sample ``pt`` along the
    unit ``rays``, sample to camera), which samples they cover, and the rule they are judged by.

    Parameters
    ----------
    who, pt : (m,) int
        Candidate and check sample of each view.
    rays : (m, 3) float
        Unit rays, sample to camera.
    covered : (n,) bool
        The samples covered.
    min_views : int
        Views a sample needs.
    min_triangulation_deg : float
        The least angle of a triangulating pair.
    max_pair_deg : float or None
        The widest angle of a matching pair.
    """

    who: np.ndarray
    pt: np.ndarray
    rays: np.ndarray
    covered: np.ndarray
    min_views: int
    min_triangulation_deg: float
    max_pair_deg: float | None


def drop_redundant(chosen: np.ndarray, views: CheckViews, sharp: list[SharpViews] = (),
                   links: np.ndarray | None = None, min_neighbours: int = 0, keep=None, braced: bool = False,
                   spare_views: int = 0) -> np.ndarray:
    """The shots of ``chosen`` (candidate indices, in the order picked) left once every shot
    the others make redundant is dropped, latest first. ``links``: (len(chosen),) * 2
    booleans, which chosen shots SfM will match (``shot_links``). ``keep``: candidate indices
    never dropped (photos already taken). ``braced``: no shot is dropped whose loss makes
    another a cut shot (``bracing.py``). ``spare_views``: the check samples a dropped shot
    covered keep that many views more than the rule asks.

    Parameters
    ----------
    chosen : (k,) int
        Candidate indices, in the order picked.
    views : CheckViews
        The views on the check samples.
    sharp : list of SharpViews
        Sharp views to keep.
    links : (k, k) bool, optional
        Which chosen shots SfM will match.
    min_neighbours : int
        Links each shot keeps.
    keep : (j,) int, optional
        Candidates never dropped.
    braced : bool
        Drop no shot whose loss makes another a cut shot.
    spare_views : int
        Views beyond the rule a dropped shot's samples keep.

    Returns
    -------
    (m,) int
        The shots kept, in ``chosen``'s order.
    """
    chosen = np.asarray(chosen, dtype=np.int64)
    n = len(chosen)
    alive = np.ones(n, dtype=bool)
    kept = np.isin(chosen, keep) if keep is not None else np.zeros(n, dtype=bool)

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
    cuts = depth_first(sp.csr_matrix(links))["cut"] if braced else np.zeros(n, dtype=bool)

    for k in range(n - 1, -1, -1):
        if kept[k]:
            continue
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
            if (np.bincount(local, minlength=len(samples)) < views.min_views + spare_views).any():
                continue
            if not has_pair_between(local, rays[entries], len(samples), views.min_triangulation_deg,
                                    views.max_pair_deg).all():
                continue
        alive[k] = False
        if len(near) > 1 and not _joined(neighbours, alive, near):
            alive[k] = True
            continue
        if braced and _new_cut(links, alive, cuts):
            alive[k] = True
            continue
        degree[near] -= 1
        for h, m in zip(have, sharp_rows):
            h[_row(m, k)] -= 1
    return chosen[alive]


def _new_cut(links: np.ndarray, alive: np.ndarray, cuts: np.ndarray) -> bool:
    """Whether the alive shots' links have a cut shot (``cut_shots``) that ``cuts`` had not."""
    idx = np.flatnonzero(alive)
    now = depth_first(sp.csr_matrix(links[np.ix_(idx, idx)]))["cut"]
    return bool((now & ~cuts[idx]).any())


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


def coverage_state(vis: sp.csr_matrix, rays: np.ndarray, chosen, min_views: int, min_triangulation_deg: float,
                   max_pair_deg: float | None = None):
    """Views per sample and whether each sample is covered by the ``chosen`` candidates.

    Parameters
    ----------
    vis : scipy.sparse.csr_matrix
        Candidates by samples.
    rays : (m, 3) float
        Unit rays in ``vis.data``'s order.
    chosen : (k,) int
        Chosen candidates.
    min_views : int
        Views a sample needs.
    min_triangulation_deg : float
        The least angle of a triangulating pair.
    max_pair_deg : float, optional
        The widest angle of a matching pair.

    Returns
    -------
    views : (n,) int
        Views per sample.
    covered : (n,) bool
        Covered samples.
    """
    _, cols, ray = _rows(vis, rays, chosen)
    views = np.bincount(cols, minlength=vis.shape[1])
    paired = has_pair_between(cols, ray, vis.shape[1], min_triangulation_deg, max_pair_deg)
    return views, (views >= min_views) & paired


def prune_redundant(vis, rays, chosen, min_views: int, min_triangulation_deg: float,
                    max_pair_deg: float | None = None, fixed: int = 0, wanted=None) -> np.ndarray:
    """Drop chosen candidates, earliest-picked last, whose removal uncovers no covered sample
    and leaves no sample without the last of its ``wanted`` views (candidates x samples, as
    ``select_views`` takes it); the first ``fixed`` are kept whatever.

    Parameters
    ----------
    vis : scipy.sparse.csr_matrix
        Candidates by samples.
    rays : (m, 3) float
        Unit rays in ``vis.data``'s order.
    chosen : (k,) int
        Chosen candidates, in the order picked.
    min_views : int
        Views a sample needs.
    min_triangulation_deg : float
        The least angle of a triangulating pair.
    max_pair_deg : float, optional
        The widest angle of a matching pair.
    fixed : int
        The first ``fixed`` of ``chosen`` are kept.
    wanted : scipy.sparse.csr_matrix, optional
        Candidates by samples, views of a kind a sample wants.

    Returns
    -------
    (m,) int
        The shots kept.
    """
    keep = np.ones(len(chosen), dtype=bool)
    _views, covered = coverage_state(vis, rays, chosen, min_views, min_triangulation_deg, max_pair_deg)
    indptr, indices = vis.indptr, vis.indices
    # Per sample, the chosen views that image it (rows of a chosen x samples matrix, by column).
    rows, cols, ray = _rows(vis, rays, chosen)
    by_sample = sp.csc_matrix((np.arange(len(rows)) + 1, (rows, cols)), shape=(len(chosen), vis.shape[1]))
    if wanted is not None:
        wanted = sp.csr_matrix(wanted)
        w_have = np.asarray(wanted[chosen].sum(axis=0)).ravel()
    for k in range(len(chosen) - 1, fixed - 1, -1):
        j = chosen[k]
        if wanted is not None and (w_have[_row(wanted, j)] <= 1).any():
            continue
        s = indices[indptr[j]:indptr[j + 1]]
        s = s[covered[s]]
        if len(s):
            sub = by_sample[:, s].tocoo()
            alive = keep[sub.row] & (sub.row != k)
            entry = sub.data[alive] - 1
            local = sub.col[alive]
            n_views = np.bincount(local, minlength=len(s))
            if (n_views < min_views).any():
                continue
            if not has_pair_between(local, ray[entry], len(s), min_triangulation_deg, max_pair_deg).all():
                continue
        keep[k] = False
        if wanted is not None:
            w_have[_row(wanted, j)] -= 1
    return chosen[keep]


def _rows(vis, rays, chosen):
    """(row in chosen, sample, ray) for every nonzero of the chosen rows."""
    chosen = np.asarray(chosen, dtype=np.int64)
    indptr = vis.indptr
    lengths = indptr[chosen + 1] - indptr[chosen]
    if lengths.sum() == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3))
    starts = np.repeat(indptr[chosen], lengths)
    offsets = run_offsets(lengths)
    entries = starts + offsets
    return np.repeat(np.arange(len(chosen)), lengths), vis.indices[entries], rays[entries]
