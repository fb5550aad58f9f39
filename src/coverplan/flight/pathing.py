"""Collision-free legs between shots: a lattice in free space, the thesis's cost, Dijkstra.

The lattice is a regular grid of spacing ``h`` over the shot region and its surroundings,
and a coarser one from there out to a distant start point.
Nodes keep the security distance (KD-tree bound, FCL where it cannot tell); an edge joins
26-neighbours when its straight segment keeps it too (Lipschitz bound from the nodes'
clearances, FCL capsules for the rest). Shots and the start join the lattice and each other
by FCL-checked segments. Edge weight = length x (1 + w x cost / K), with the cost of thesis
Eq. 3.2-3.3: security term K - d(scene) plus optimal-placement term |d(target) - d_opt|.
Legs are shortened afterwards by replacing runs of nodes with straight safe segments.
"""

from __future__ import annotations

from concurrent.futures import Executor
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from coverplan.geometry.clearance import surface_cover

_NEIGHBOURS = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)
                        if (i, j, k) > (0, 0, 0)])  # 13 of the 26: each edge once


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


def lattice_spacing(d_opt: float, security: float, volume: float, max_nodes: int) -> float:
    """The flight graph's lattice spacing: a third of d_opt at most, coarser where the volume would need more than ``max_nodes`` nodes.

    Parameters
    ----------
    d_opt : float
        The optimal distance, metres.
    security : float
        The security distance, metres.
    volume : float
        The lattice's volume, cubic metres.
    max_nodes : int
        The most nodes.

    Returns
    -------
    float
        Metres.
    """
    h = min(d_opt / 3.0, max(security, d_opt / 6.0))
    return float(max(h, (volume / max_nodes) ** (1.0 / 3.0)))


def node_costs(points, scene_distance, target_distance, d_opt: float) -> tuple[np.ndarray, float]:
    """Thesis cost per point: (K - d(scene)) + |d(target) - d_opt|, with K the largest d(scene).

    Parameters
    ----------
    points : (n, 3) float
        Lattice nodes.
    scene_distance : (n,) float
        Their distance to the scene.
    target_distance : (n,) float
        Their distance to the target.
    d_opt : float
        The optimal distance, metres.

    Returns
    -------
    cost : (n,) float
        Metres.
    k : float
        The largest distance to the scene.
    """
    k = float(scene_distance.max()) if len(scene_distance) else 1.0
    return (k - scene_distance) + np.abs(target_distance - d_opt), max(k, 1e-9)


def _lattice(clearance, limits, lo, hi, spacing: float, radius: float, far: float, hole=None):
    """Safe nodes of a regular lattice over the box [lo, hi] (none strictly inside the box
    ``hole``), their distance bounds, and the 26-neighbour edges whose segments are safe
    (clear of the meshes, above the minimum altitude)."""
    shape = np.floor((hi - lo) / spacing).astype(int) + 1
    grid = np.stack(np.meshgrid(*[np.arange(s) for s in shape], indexing="ij"), axis=-1).reshape(-1, 3)
    nodes = lo + grid * spacing
    if hole is not None:
        outside = ~((nodes > hole[0]) & (nodes < hole[1])).all(axis=1)
        grid, nodes = grid[outside], nodes[outside]
    upper, _owner = clearance.kd_distance(nodes, far)
    upper = np.minimum(upper, far)
    lower = np.maximum(upper - clearance.cover_radius, 0.0)
    high = limits.allowed(nodes)
    ok = (lower >= radius) & high
    unsure = np.flatnonzero(~ok & (upper >= radius) & high)
    if len(unsure):
        ok[unsure] = clearance.points_clear(nodes[unsure], radius, check_inside=False)
    # Nodes inside buildings stay in components the start cannot reach; no inside test needed.
    keep_grid = grid[ok]
    nodes, lower, upper = nodes[ok], lower[ok], upper[ok]
    flat = np.full(tuple(shape), -1, dtype=np.int64)
    flat[tuple(keep_grid.T)] = np.arange(len(nodes))
    rows, cols = [], []
    for step in _NEIGHBOURS:
        other = keep_grid + step
        inside = ((other >= 0) & (other < shape)).all(axis=1)
        a = np.flatnonzero(inside)
        b = flat[tuple(other[inside].T)]
        live = b >= 0
        rows.append(a[live])
        cols.append(b[live])
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    if len(rows):
        safe = clearance.segments_clear(nodes[rows], nodes[cols], radius, lower[rows], lower[cols], exact=False)
        safe[safe] = limits.segments_allowed(nodes[rows[safe]], nodes[cols[safe]])
        rows, cols = rows[safe], cols[safe]
    return nodes, lower, upper, rows, cols


@dataclass
class Lattice:
    """The safe lattice of a flight graph before the start and shots join it: fine nodes over
    ``box`` at ``spacing``, then coarse nodes out to ``start``; each node's distance bounds to
    the scene and distance to the target (for the cost); safe edges ``rows`` -> ``cols``.

    Parameters
    ----------
    box : ((3,) float, (3,) float)
        The fine lattice's box.
    start : (3,) float
        The take-off point.
    spacing : float
        The fine spacing, metres.
    radius : float
        The clearance the edges keep, metres.
    nodes : (n, 3) float
        Fine then coarse nodes.
    lower, upper : (n,) float
        Bounds of each node's distance to the scene.
    target_d : (n,) float
        Each node's distance to the target.
    target_tree : scipy.spatial.cKDTree
        Over points covering the target's surface.
    rows, cols : (e,) int
        Safe edges.
    n_fine : int
        Fine nodes.
    coarse_step : float or None
        The coarse spacing; None without coarse nodes.
    """

    box: tuple[np.ndarray, np.ndarray]
    start: np.ndarray
    spacing: float
    radius: float
    nodes: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    target_d: np.ndarray
    target_tree: cKDTree  # over points covering the target's surface
    rows: np.ndarray
    cols: np.ndarray
    n_fine: int
    coarse_step: float | None

    def serves(self, box, start, spacing: float, radius: float) -> bool:
        """Whether this lattice is the one ``build_lattice`` would make for these.

        Parameters
        ----------
        box : ((3,) float, (3,) float)
            The fine lattice's box.
        start : (3,) float
            The take-off point.
        spacing : float
            Metres.
        radius : float
            Metres.

        Returns
        -------
        bool
            True when it can be used.
        """
        return (self.spacing == spacing and self.radius == radius and np.array_equal(self.start, start)
                and all(np.array_equal(a, b) for a, b in zip(self.box, box)))


def lattice_box(scene, limits, shots, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """The fine lattice's box: the target's and the shots' with room around them.

    Parameters
    ----------
    scene : Scene
        The scene.
    limits : ViewLimits
        The altitude band.
    shots : (k, 3) float
        Shot positions.
    spacing : float
        Metres.

    Returns
    -------
    lo, hi : (3,) float
        The box's corners.
    """
    shots = np.asarray(shots, dtype=float).reshape(-1, 3)
    lo, hi = scene.bounds("target")
    pad = limits.d_opt + 2 * spacing
    lo = np.minimum(lo - pad, shots.min(axis=0, initial=np.inf) - spacing)
    hi = np.maximum(hi + pad, shots.max(axis=0, initial=-np.inf) + spacing)
    lo[2] = limits.lowest_floor(lo, hi)
    hi[2] = max(hi[2], lo[2] + spacing)
    return lo, hi


def build_lattice(scene, limits, box, start, *, margin: float, spacing: float,
                  max_coarse_nodes: int = 50_000) -> Lattice:
    """The lattice over ``box`` (``lattice_box``) at ``spacing``, and a coarser one (at least
    3x the spacing) between it and a start outside it, so a take-off far away does not coarsen
    the paths between shots.

    Parameters
    ----------
    scene : Scene
        The scene.
    limits : ViewLimits
        Security distance, altitude band and zones.
    box : ((3,) float, (3,) float)
        The fine lattice's box.
    start : (3,) float
        The take-off point.
    margin : float
        Clearance kept beyond the security distance, metres.
    spacing : float
        Metres.
    max_coarse_nodes : int
        The most coarse nodes.

    Returns
    -------
    Lattice
        Nodes and safe edges.
    """
    clearance = scene.clearance_model(limits.security)
    radius = limits.security + margin
    start = np.asarray(start, dtype=float).reshape(3)
    far = radius + 2.0 * limits.d_opt + spacing * 2  # distances matter up to here (for the cost)
    lo, hi = box
    nodes, lower, upper, rows, cols = _lattice(clearance, limits, lo, hi, spacing, radius, far)
    fine_lo, fine_hi = lo, lo + (np.floor((hi - lo) / spacing)) * spacing  # the outermost fine nodes
    n_fine = len(nodes)
    step = None
    if not ((start >= fine_lo) & (start <= fine_hi)).all():
        c_lo = np.minimum(fine_lo, start)
        c_hi = np.maximum(fine_hi, start)
        c_hi[2] = max(c_hi[2], start[2] + spacing)
        big = float(np.prod(c_hi - c_lo + 2 * spacing))
        step = max(3.0 * spacing, (big / max_coarse_nodes) ** (1.0 / 3.0))
        c_lo = c_lo - step
        c_hi = c_hi + step
        c_lo[2] = limits.lowest_floor(c_lo, c_hi)
        c_nodes, c_lower, c_upper, c_rows, c_cols = _lattice(clearance, limits, c_lo, c_hi, step, radius, far,
                                                             hole=(fine_lo, fine_hi))
        # Join the two lattices: each coarse node near the fine box to its nearest fine nodes.
        if len(c_nodes) and n_fine:
            gap = np.maximum(np.maximum(fine_lo - c_nodes, c_nodes - fine_hi), 0.0).max(axis=1)
            rim = np.flatnonzero(gap <= 1.5 * step)
            d, j = cKDTree(nodes).query(c_nodes[rim], k=8, distance_upper_bound=2.0 * step)
            live = np.isfinite(d)
            a = np.repeat(rim, 8).reshape(-1, 8)[live]
            b = j[live]
            safe = clearance.segments_clear(c_nodes[a], nodes[b], radius, c_lower[a], lower[b], exact=False)
            safe[safe] = limits.segments_allowed(c_nodes[a[safe]], nodes[b[safe]])
            link_r, link_c = a[safe] + n_fine, b[safe]
        else:
            link_r = link_c = np.zeros(0, dtype=np.int64)
        rows = np.concatenate([rows, c_rows + n_fine, link_r])
        cols = np.concatenate([cols, c_cols + n_fine, link_c])
        nodes = np.vstack([nodes, c_nodes])
        lower = np.concatenate([lower, c_lower])
        upper = np.concatenate([upper, c_upper])
    target_tree = cKDTree(np.vstack([surface_cover(p.mesh, clearance.cover_edge)[0] for p in scene.targets]))
    return Lattice((lo, hi), start, spacing, radius, nodes, lower, upper, _distance(target_tree, nodes, far),
                   target_tree, rows, cols, n_fine, step)


def _distance(tree: cKDTree, points, far: float) -> np.ndarray:
    return np.minimum(tree.query(points, workers=-1, distance_upper_bound=far)[0], far)


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
