"""The thesis's Path-planner (Chapter 3.4): cost function, directed grid graph, Dijkstra.

c = s + op with s = K - d(target or obstacle) (K the largest such distance) and
op = distance to the optimal-distance ring around the target, ignoring obstacles
(Eq. 3.2-3.3); infinite in the target, obstacles and under the security distance. Each
directed edge to a neighbouring cell weighs the cost of the cell it ends in.
"""

from __future__ import annotations

import itertools

import numpy as np
import scipy.sparse as sp
from scipy import ndimage
from scipy.sparse.csgraph import dijkstra

from coverplan.voxel.grid import FREE, TARGET


def cost_grid(cells: np.ndarray, d_opt: float, d_sec: float) -> np.ndarray:
    """The thesis's placement cost: security (far from blocked cells) plus optimality (near the ring at d_opt from the target).

    Parameters
    ----------
    cells : ndarray of int8
        A 2D or 3D grid's cells.
    d_opt : float
        The optimal distance, in cells.
    d_sec : float
        The security distance, in cells.

    Returns
    -------
    ndarray of float
        Cost per cell, inf where the drone may not be.
    """
    d_blocked = ndimage.distance_transform_edt(cells == FREE)
    d_target = ndimage.distance_transform_edt(cells != TARGET)
    ring = np.abs(d_target - d_opt) <= 0.5
    op = ndimage.distance_transform_edt(~ring) if ring.any() else np.zeros(cells.shape)
    cost = (d_blocked.max() - d_blocked) + op
    cost[(cells != FREE) | (d_blocked < d_sec)] = np.inf
    return cost


def grid_graph(cost: np.ndarray) -> sp.csr_matrix:
    """Directed graph over cells (8- or 26-neighbours) weighted by the end cell's cost.

    Parameters
    ----------
    cost : ndarray of float
        ``cost_grid``'s cost per cell.

    Returns
    -------
    scipy.sparse.csr_matrix
        Cells by cells.
    """
    shape = cost.shape
    flat = np.arange(cost.size).reshape(shape)
    rows, cols = [], []
    for step in itertools.product((-1, 0, 1), repeat=cost.ndim):
        if not any(step):
            continue
        src = tuple(slice(max(0, -s), n - max(0, s)) for s, n in zip(step, shape))
        dst = tuple(slice(max(0, s), n - max(0, -s)) for s, n in zip(step, shape))
        a, b = flat[src].ravel(), flat[dst].ravel()
        ok = np.isfinite(cost.ravel()[a]) & np.isfinite(cost.ravel()[b])
        rows.append(a[ok])
        cols.append(b[ok])
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    weight = np.maximum(cost.ravel()[cols], 1e-9)  # an explicit 0 would vanish from the graph
    return sp.csr_matrix((weight, (rows, cols)), shape=(cost.size, cost.size))


def cell_path(graph: sp.csr_matrix, shape, a, b) -> np.ndarray | None:
    """Cells (k, ndim) of the cheapest path from cell a to cell b, or None when none exists.

    Parameters
    ----------
    graph : scipy.sparse.csr_matrix
        ``grid_graph``'s graph.
    shape : tuple of int
        The grid's shape.
    a, b : sequence of int
        Start and end cells.

    Returns
    -------
    (k, ndim) int or None
        The path's cells, from ``a`` to ``b``.
    """
    ia = int(np.ravel_multi_index(tuple(a), shape))
    ib = int(np.ravel_multi_index(tuple(b), shape))
    if ia == ib:
        return np.array([a])
    dist, pred = dijkstra(graph, directed=True, indices=ia, return_predecessors=True)
    if not np.isfinite(dist[ib]):
        return None
    path = [ib]
    while path[-1] != ia:
        path.append(pred[path[-1]])
    return np.array(np.unravel_index(np.array(path[::-1]), shape)).T
