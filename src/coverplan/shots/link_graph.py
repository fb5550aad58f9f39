"""The link graph's shape: connected pieces, neighbour counts and the cut shots (articulation points) whose loss would split it."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from coverplan.shots.knitting import edge_classes, thin_groups
from coverplan.shots.reconstructability import MatchRule

THIN_CUT = 3  # links a group of photos needs to the rest: the square's roof grid on two came apart in the field


def cut_shots(links: sp.spmatrix) -> np.ndarray:
    """The shots (rows of the symmetric ``links``) whose removal splits their piece of the
    graph: its articulation points, by Tarjan's low-link on an explicit stack.

    Parameters
    ----------
    links : (n, n) sparse or dense
        Symmetric link matrix.

    Returns
    -------
    (k,) int
        Sorted indices of the cut shots.
    """
    return np.flatnonzero(depth_first(links)["cut"])


def depth_first(links: sp.spmatrix) -> dict:
    """Tarjan's depth-first search of the symmetric ``links`` (n, n), on an explicit stack.

    Parameters
    ----------
    links : scipy.sparse.spmatrix
        Symmetric links.

    Returns
    -------
    dict of (n,) arrays
        ``order``: preorder number (a subtree holds the numbers ``order[w]`` up to
        ``order[w] + size[w]``); ``low``: its low-link; ``parent``: -1 at a root; ``size``:
        shots in the subtree; ``root``: the root of the shot's tree; ``cut``: bool, the cut shots.
    """
    g = sp.csr_matrix(links)
    n = g.shape[0]
    indptr, indices = g.indptr, g.indices
    order = np.full(n, -1, dtype=np.int64)
    low = np.zeros(n, dtype=np.int64)
    parent = np.full(n, -1, dtype=np.int64)
    size = np.ones(n, dtype=np.int64)
    root_of = np.zeros(n, dtype=np.int64)
    cut = np.zeros(n, dtype=bool)
    clock = 0
    for root in range(n):
        if order[root] >= 0:
            continue
        order[root] = low[root] = clock
        root_of[root] = root
        clock += 1
        children = 0
        stack = [(root, indptr[root])]
        while stack:
            v, at = stack[-1]
            if at < indptr[v + 1]:
                stack[-1] = (v, at + 1)
                w = indices[at]
                if w == v:
                    continue
                if order[w] < 0:
                    parent[w] = v
                    root_of[w] = root
                    order[w] = low[w] = clock
                    clock += 1
                    if v == root:
                        children += 1
                    stack.append((w, indptr[w]))
                elif w != parent[v]:
                    low[v] = min(low[v], order[w])
            else:
                stack.pop()
                p = parent[v]
                if p >= 0:
                    low[p] = min(low[p], low[v])
                    size[p] += size[v]
                    if p != root and low[v] >= order[p]:
                        cut[p] = True
        if children > 1:
            cut[root] = True
    return {"order": order, "low": low, "parent": parent, "size": size, "root": root_of, "cut": cut}


def graph_summary(links: np.ndarray, rule: MatchRule = MatchRule()) -> dict:
    """Neighbour counts and connected pieces of a link matrix, as the reports state them.

    Parameters
    ----------
    links : (n, n) bool
        Links.
    rule : MatchRule
        Gives ``min_neighbours``.

    Returns
    -------
    dict
        Shots, components, largest component, shots short of neighbours, cut shots, and the
        groups of ``knitting.MIN_GROUP`` photos or more beyond the largest that fewer than
        ``THIN_CUT`` links join to the rest (``thin_groups``, the photos in them ``thin_group_shots``).
    """
    n = len(links)
    if n == 0:
        return {"shots": 0, "components": 0, "largest_component": 0, "shots_short_of_neighbours": 0,
                "median_neighbours": 0.0, "cut_shots": 0, "thin_groups": 0, "thin_group_shots": 0}
    degree = links.sum(axis=1)
    classes = edge_classes(links, THIN_CUT)
    thin = thin_groups(classes)
    n_comp, label = connected_components(sp.csr_matrix(links), directed=False)
    return {"shots": int(n), "components": int(n_comp),
            "largest_component": int(np.bincount(label).max()),
            "shots_short_of_neighbours": int((degree < rule.min_neighbours).sum()),
            "median_neighbours": float(np.median(degree)), "cut_shots": len(cut_shots(links)),
            "thin_groups": len(thin), "thin_group_shots": int(np.isin(classes, thin).sum())}
