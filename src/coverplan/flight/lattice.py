"""The flight graph's lattice: safe nodes over the target and its shots at the lattice spacing, coarser ones out to a far take-off, and the safe edges between them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from coverplan.geometry.surface_cover import surface_cover

_NEIGHBOURS = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)
                        if (i, j, k) > (0, 0, 0)])  # 13 of the 26: each edge once


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
    """Thesis cost per point: (K - d(scene)) + ``abs(d(target) - d_opt)``, with K the largest d(scene).

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
