"""Collision-free legs between shots: a lattice in free space, the thesis's cost, Dijkstra.

The lattice is a regular grid of spacing ``h`` over the shot region and its surroundings,
and a coarser one from there out to a distant start point.
Nodes keep the security distance (KD-tree bound, FCL where it cannot tell); an edge joins
26-neighbours when its straight segment keeps it too (Lipschitz bound from the nodes'
clearances, FCL capsules for the rest). Shots and the start join the lattice and each other
by FCL-checked segments. Edge weight = length x (1 + w x cost / K), with the cost of thesis
Eq. 3.2-3.3: security term K - d(scene) plus optimal-placement term ``abs(d(target) - d_opt)``.
Legs are shortened afterwards by replacing runs of nodes with straight safe segments.
"""

from __future__ import annotations

from concurrent.futures import Executor
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from coverplan.flight.lattice import Lattice, _distance, build_lattice, lattice_box, node_costs


@dataclass
class FlightGraph:
    """Lattice nodes followed by the special points (start first, then shots).

    Parameters
    ----------
    points : (n, 3) float
        Lattice nodes, then the start, then the shots.
    graph : scipy.sparse.csr_matrix
        Safe, cost-weighted edges.
    n_lattice : int
        How many of ``points`` are lattice nodes.
    spacing : float
        The lattice spacing, metres.
    """

    points: np.ndarray  # (n, 3)
    graph: sp.csr_matrix  # symmetric weights
    n_lattice: int
    spacing: float

    def special(self, k: int) -> int:
        """Graph index of special point k (0 = start, 1.. = shots).

        Parameters
        ----------
        k : int or (m,) int
            Special indices.

        Returns
        -------
        int or (m,) int
            Graph indices.
        """
        return self.n_lattice + k


def build_flight_graph(scene, limits, specials, *, margin: float, spacing: float,
                       cost_weight: float = 1.0, max_coarse_nodes: int = 50_000, progress=None,
                       lattice: Lattice | None = None) -> FlightGraph:
    """Lattice + special points (start, shots) with safe, cost-weighted edges.

    The lattice (``build_lattice``) has ``spacing`` around the target and its shots; a
    ``lattice`` built beforehand is used when it is the one these specials ask for.

    Parameters
    ----------
    scene : Scene
        The scene.
    limits : ViewLimits
        Security distance, altitude band and zones.
    specials : (s, 3) float
        The start, then the shots.
    margin : float
        Clearance kept beyond the security distance, metres.
    spacing : float
        Metres.
    cost_weight : float
        The weight of the placement cost against length.
    max_coarse_nodes : int
        The most coarse nodes.
    progress : Progress, optional
        Reports the stage.
    lattice : Lattice, optional
        Built beforehand.

    Returns
    -------
    FlightGraph
        The graph.
    """
    clearance = scene.clearance_model(limits.security)
    radius = limits.security + margin
    specials = np.asarray(specials, dtype=float).reshape(-1, 3)
    far = radius + 2.0 * limits.d_opt + spacing * 2
    box = lattice_box(scene, limits, specials[1:], spacing)
    if lattice is None or not lattice.serves(box, specials[0], spacing, radius):
        lattice = build_lattice(scene, limits, box, specials[0], margin=margin, spacing=spacing,
                                max_coarse_nodes=max_coarse_nodes)
    nodes, upper, rows, cols = lattice.nodes, lattice.upper, lattice.rows, lattice.cols
    n_fine, step = lattice.n_fine, lattice.coarse_step
    if progress is not None:
        progress(1)

    # Special points join lattice nodes and each other where the straight segment is safe.
    points = np.vstack([nodes, specials])
    n_lat = len(nodes)
    reach = spacing * 2.0
    extra_r, extra_c = [], []
    # Specials join the fine lattice; a start outside it joins the coarse one as well.
    groups = [(np.arange(len(specials)), 0, n_fine, reach)]
    if step is not None:
        groups.append((np.array([0]), n_fine, n_lat, 2.0 * step))
    for which, first, stop, r in groups:
        if stop <= first or not len(which):
            continue
        near = cKDTree(nodes[first:stop]).query_ball_point(specials[which], r)
        a = np.repeat(which, [len(x) for x in near]) + n_lat
        b = np.concatenate([np.asarray(x, dtype=np.int64) + first for x in near]) if len(a) else np.zeros(0, np.int64)
        extra_r.append(a)
        extra_c.append(b)
    pairs = cKDTree(specials).query_pairs(max(reach, limits.d_opt), output_type="ndarray")
    if len(pairs):
        extra_r.append(pairs[:, 0] + n_lat)
        extra_c.append(pairs[:, 1] + n_lat)
    if extra_r:
        er, ec = np.concatenate(extra_r), np.concatenate(extra_c)
        safe = clearance.segments_clear(points[er], points[ec], radius)  # exact: shots sit near the limit
        safe[safe] = limits.segments_allowed(points[er[safe]], points[ec[safe]])
        rows = np.concatenate([rows, er[safe]])
        cols = np.concatenate([cols, ec[safe]])

    scene_d = np.concatenate([upper, np.minimum(clearance.kd_distance(specials, far)[0], far)])
    target_d = np.concatenate([lattice.target_d, _distance(lattice.target_tree, specials, far)])
    cost, k = node_costs(points, scene_d, target_d, limits.d_opt)
    length = np.linalg.norm(points[rows] - points[cols], axis=1)
    weight = length * (1.0 + cost_weight * (cost[rows] + cost[cols]) / (2.0 * k))
    weight = np.maximum(weight, 1e-9)  # explicit zeros would vanish from the sparse graph
    n = len(points)
    graph = sp.coo_matrix((weight, (rows, cols)), shape=(n, n)).tocsr()
    graph = graph.maximum(graph.T).tocsr()
    return FlightGraph(points, graph, n_lat, spacing)


_DIJKSTRA_ROWS = 64  # sources per scipy call: the (sources, graph nodes) result stays small


def shot_distances(fg: FlightGraph, n_special: int, limit: float, pool: Executor | None = None):
    """Shortest-path costs between all special points (start + shots).

    Dijkstra from each shot is cut at ``limit``; farther pairs get their cost through chains of
    nearer shots (a shortest-path closure over the special points), and the start is searched
    without limit so every reachable shot connects. With ``pool``, every other block of
    sources is searched there (scipy's Dijkstra runs without the GIL), with the same result.
    Returns (closure, its predecessors, the direct costs).

    Parameters
    ----------
    fg : FlightGraph
        The graph.
    n_special : int
        Specials (start and shots).
    limit : float
        The Dijkstra cut-off cost.
    pool : Executor, optional
        Runs half the searches.

    Returns
    -------
    closure : (s, s) float
        Costs.
    pred : (s, s) int
        The closure's predecessors.
    direct : (s, s) float
        Costs found directly.
    """
    # The graphs are symmetric: directed=True gives the same paths and spares scipy a
    # conversion of the whole graph on every call.
    idx = fg.n_lattice + np.arange(n_special)

    def search(sources, cut=np.inf):
        return dijkstra(fg.graph, directed=True, indices=sources, limit=cut)[:, idx]

    blocks = np.array_split(idx[1:], -(-(n_special - 1) // _DIJKSTRA_ROWS)) if n_special > 1 else []
    away = [pool.submit(search, b, limit) for b in blocks[1::2]] if pool is not None else []
    rows = [search(idx[:1])]
    for j, b in enumerate(blocks):
        rows.append(away[j // 2].result() if j % 2 and away else search(b, limit))
    direct = np.vstack(rows)
    direct = np.minimum(direct, direct.T)
    np.fill_diagonal(direct, 0.0)
    finite = np.isfinite(direct)
    closure, pred = dijkstra(sp.csr_matrix(np.where(finite, np.maximum(direct, 1e-9), 0.0)),
                             directed=True, return_predecessors=True)
    return closure, pred, direct


def closure_hops(pred, u: int, v: int) -> list[int]:
    """Special points from u to v along the closure's shortest path (u and v included).

    Parameters
    ----------
    pred : (s, s) int
        The closure's predecessors.
    u, v : int
        Special indices.

    Returns
    -------
    list of int
        Special indices.
    """
    hops = [v]
    while hops[-1] != u:
        hops.append(int(pred[u, hops[-1]]))
    return hops[::-1]


def leg(fg: FlightGraph, a: int, b: int, cost: float) -> np.ndarray:
    """Graph nodes of the cheapest path from node a to node b (both included), whose cost is
    known to be ``cost`` (the search stops there).

    Parameters
    ----------
    fg : FlightGraph
        The graph.
    a, b : int
        Graph nodes.
    cost : float
        The path's known cost.

    Returns
    -------
    (k,) int
        Graph nodes.
    """
    if a == b:
        return np.array([a])
    dist, pred = dijkstra(fg.graph, directed=True, indices=a, return_predecessors=True,
                          limit=cost * (1 + 1e-9) + 1e-9)
    if not np.isfinite(dist[b]):
        raise RuntimeError(f"no path between graph nodes {a} and {b}")
    path = [b]
    while path[-1] != a:
        path.append(pred[path[-1]])
    return np.array(path[::-1])


def shortcut(points, clearance, radius: float, batch: int = 8, floor=None) -> np.ndarray:
    """Indices of a subsequence of ``points`` whose straight segments all stay safe (and,
    given ``floor`` (starts, ends) -> bool, above the minimum altitude).

    From each kept point, jump to the farthest later point in view: the farthest is tried
    first (most legs are then one segment), then the next ``batch`` farthest, and so on.

    Parameters
    ----------
    points : (n, 3) float
        A safe polyline.
    clearance : ClearanceModel
        Checks segments.
    radius : float
        Metres.
    batch : int
        Later points tried per round.
    floor : callable, optional
        ``floor(starts, ends)``.

    Returns
    -------
    (k,) int
        Indices into ``points``, first and last included.
    """
    keep = [0]
    i = 0
    n = len(points)
    while i < n - 1:
        nxt = i + 1  # consecutive path points are joined by a checked edge already
        for hi in range(n - 1, i + 1, -batch):
            j = np.arange(hi, max(hi - batch, i + 1), -1)
            a = np.repeat(points[i:i + 1], len(j), axis=0)
            ok = clearance.segments_clear(a, points[j], radius, exact=False)
            if floor is not None:
                ok &= floor(a, points[j])
            if ok.any():
                nxt = int(j[np.argmax(ok)])
                break
        keep.append(nxt)
        i = nxt
    return np.array(keep)


def polyline_checks(points, clearance, limits) -> tuple[np.ndarray, np.ndarray]:
    """Per segment of the polyline ``points`` (n, 3): whether it keeps the security distance
    (exact), and whether it and its two ends stay within the altitude band and out of the
    zones. Both (n - 1,) bool.

    Parameters
    ----------
    points : (n, 3) float
        The polyline.
    clearance : ClearanceModel
        Checks segments.
    limits : ViewLimits
        Security distance, altitude band and zones.

    Returns
    -------
    clear : (n - 1,) bool
        Keeps the security distance.
    allowed : (n - 1,) bool
        Within the altitude band and out of the zones.
    """
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    if len(p) < 2:
        return np.zeros(0, dtype=bool), np.zeros(0, dtype=bool)
    clear = clearance.segments_clear(p[:-1], p[1:], limits.security)
    ends = limits.allowed(p)
    return clear, limits.segments_allowed(p[:-1], p[1:]) & ends[:-1] & ends[1:]
