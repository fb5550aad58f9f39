"""Linking shots into one photo set: candidates added until every photo has its neighbours and the links join all of them."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from coverplan.shots.reconstructability import MatchRule, candidate_links


def connect_shots(vis: sp.csr_matrix, positions: np.ndarray, points: np.ndarray, chosen: np.ndarray,
                  rule: MatchRule = MatchRule(), max_added: int | None = None,
                  links: sp.csr_matrix | None = None, normals: np.ndarray | None = None) -> np.ndarray:
    """Add candidates (rows of ``vis``) to ``chosen`` until every chosen shot has
    ``rule.min_neighbours`` links and the links join all shots in one piece, or nothing helps.
    ``links``: ``candidate_links(vis, positions, points, rule)`` if already worked out.

    Shots short of neighbours get, one at a time, the candidate linked to most of them. Pieces
    left apart are joined along chains of linked candidates (Dijkstra over the candidate link
    graph from the largest piece), two ways: every piece at once along its shortest chain, or
    the nearest piece first, counting the candidates already taken as free, then again from
    the grown piece (a Steiner-tree heuristic: later chains run through earlier ones). Neither
    is the shorter on every scene, so for a lean rule (``MatchRule.lean``) both run and the one
    adding fewer shots is kept; otherwise the first alone.

    Parameters
    ----------
    vis : scipy.sparse.csr_matrix
        Candidates by samples.
    positions : (n, 3) float
        Candidate centres.
    points : (m, 3) float
        Samples.
    chosen : (k,) int
        Chosen candidates.
    rule : MatchRule
        The matching rule.
    max_added : int, optional
        The most candidates added.
    links : scipy.sparse.csr_matrix, optional
        The candidates' links.
    normals : (m, 3) float, optional
        Sample normals.

    Returns
    -------
    (j,) int
        ``chosen`` and the candidates added.
    """
    chosen = [int(j) for j in chosen]
    if len(chosen) < 2:
        return np.array(chosen, dtype=np.int64)
    budget = len(chosen) if max_added is None else int(max_added)
    links = candidate_links(vis, positions, points, rule, normals=normals) if links is None else links
    links = sp.csr_matrix(links)
    ways = (False, True) if rule.lean else (False,)
    joined = [_connect(links, chosen, rule.min_neighbours, budget, nearest) for nearest in ways]
    return min(joined, key=len)


def _connect(links: sp.csr_matrix, start: list[int], min_neighbours: int, budget: int, nearest: bool) -> np.ndarray:
    """``connect_shots`` with one way of joining the pieces (``nearest``: the Steiner one)."""
    from scipy.sparse.csgraph import dijkstra

    chosen = list(start)
    n = links.shape[0]
    taken = np.zeros(n, dtype=bool)
    taken[chosen] = True
    added = 0

    def add(j: int) -> None:
        nonlocal added
        chosen.append(int(j))
        taken[j] = True
        added += 1

    def pieces():
        idx = np.array(chosen)
        n_comp, label = connected_components(links[idx][:, idx], directed=False)
        return idx, n_comp, label

    def chain(pred, end) -> bool:
        """Add the untaken candidates on the chain from ``end`` back to the largest piece."""
        grew = False
        node = pred[end]
        while node >= 0 and added < budget:
            if not taken[node]:
                add(node)
                grew = True
            elif not nearest:  # the old chains stop at the first shot already taken
                break
            node = pred[node]
        return grew

    for _pass in range(3):
        # 1. every shot its neighbours (links is symmetric: degrees are one product)
        while added < budget:
            degree = links @ taken.astype(float)
            short_mask = taken & (degree < min_neighbours)
            if not short_mask.any():
                break
            score = links @ short_mask.astype(float)
            score[taken] = 0
            best = int(np.argmax(score))
            if score[best] <= 0:
                break
            add(best)
        # 2. one piece
        idx, n_comp, label = pieces()
        if n_comp == 1 or added >= budget:
            break
        grew = False
        if not nearest:
            main = idx[label == np.argmax(np.bincount(label))]
            dist, pred, _src = dijkstra(links, indices=main, unweighted=True, min_only=True,
                                        return_predecessors=True)
            for comp in range(n_comp):
                members = idx[label == comp]
                if np.isin(members, main).any():
                    continue
                end = members[np.argmin(dist[members])]
                if np.isfinite(dist[end]):
                    grew |= chain(pred, end)
        else:
            step = links.copy()
            step.eliminate_zeros()
            while n_comp > 1 and added < budget:
                main_label = int(np.argmax(np.bincount(label)))
                # entering a taken candidate costs (almost) nothing: chains reuse the shots there
                step.data = np.where(taken[step.indices], 1e-6, 1.0)
                dist, pred, _src = dijkstra(step, directed=True, indices=idx[label == main_label], min_only=True,
                                            return_predecessors=True)
                rest = idx[label != main_label]
                end = rest[np.argmin(dist[rest])]
                if not np.isfinite(dist[end]) or not chain(pred, end):
                    break
                grew = True
                idx, n_comp, label = pieces()
        if not grew:
            break
    return np.array(chosen, dtype=np.int64)
