"""The thesis's View-planner on one 2D grid (Chapter 3.3), as written.

Shot region from distance transforms (Eq. 3.1); surface points organised into a chain from
an extreme point of the first image (3.3.2); two checking loops (3.3.3): a viewpoint looking
at each unseen point that sees the most unseen points, then at each point seen once that
sees the most points seen once, ties broken by the distance from the previous viewpoint and
the area around first-loop viewpoints barred in the second; viewpoints then arranged by
proximity, starting with the first shot. Distances are in cells.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from coverplan.voxel.grid import FREE, TARGET

BAR_RADIUS = 1  # cells around a first-loop viewpoint barred in the second loop


@dataclass
class Viewpoints:
    """Result of the view planner: cells, yaw (radians, counter-clockwise from +x), and why it
    stopped when it could not cover every surface point.

    Parameters
    ----------
    cells : (k, 2) int
        The viewpoints' cells, in order.
    yaw : (k,) float
        Radians, counter-clockwise from +x.
    surface : (n, 2) int
        The surface cells, organised into a chain.
    seen : (n,) int
        How many viewpoints see each surface cell.
    failure : str, optional
        Why the planner stopped short.
    loops : list
        The planner's rounds, for plots.
    """

    cells: np.ndarray  # (k, 2) int
    yaw: np.ndarray  # (k,)
    surface: np.ndarray  # (n, 2) organised surface cells
    seen: np.ndarray  # (n,) how many shots see each surface point
    failure: str | None = None
    loops: list = field(default_factory=list)  # 0 first shot, 1 / 2 checking loop


def shot_region(cells: np.ndarray, d_opt: float, d_sec: float) -> np.ndarray:
    """Eq. 3.1: free cells within d_opt of the target and at least d_sec from target and obstacles.

    Parameters
    ----------
    cells : ndarray of int8
        A grid's cells.
    d_opt, d_sec : float
        Optimal and security distances, in cells.

    Returns
    -------
    ndarray of bool
        The shot region.
    """
    d_target = ndimage.distance_transform_edt(cells != TARGET)
    d_blocked = ndimage.distance_transform_edt(cells == FREE)
    return (cells == FREE) & (d_target <= d_opt) & (d_blocked >= d_sec)


def surface_cells(cells: np.ndarray, next_to=None) -> np.ndarray:
    """Target cells with a 4-neighbour that is not target (the thesis's surface points), or,
    with ``next_to``, one whose value is ``next_to``.

    Parameters
    ----------
    cells : (nx, ny) int8
        A 2D grid's cells.
    next_to : int, optional
        The neighbour value asked for.

    Returns
    -------
    (n, 2) int
        The surface cells.
    """
    target = cells == TARGET
    other = (cells != TARGET) if next_to is None else (cells == next_to)
    padded = np.pad(other, 1, constant_values=next_to is None or next_to == FREE)
    border = padded[:-2, 1:-1] | padded[2:, 1:-1] | padded[1:-1, :-2] | padded[1:-1, 2:]
    return np.argwhere(target & border)


def line_of_sight(cells: np.ndarray, viewpoints: np.ndarray, points: np.ndarray, step: float = 0.25,
                  chunk: int = 64) -> np.ndarray:
    """(k, n) bool: every cell on the segment from each viewpoint to each surface point, the
    point's own cell excepted, is free (the thesis sums the cells' values).

    Parameters
    ----------
    cells : (nx, ny) int8
        A 2D grid's cells.
    viewpoints : (k, 2) float
        Cell coordinates.
    points : (n, 2) int
        Surface cells.
    step : float
        Sampling step along each segment, in cells.
    chunk : int
        Viewpoints per batch.

    Returns
    -------
    (k, n) bool
        Visibility.
    """
    vis = np.zeros((len(viewpoints), len(points)), dtype=bool)
    if len(viewpoints) == 0 or len(points) == 0:
        return vis
    a = viewpoints.astype(float) + 0.5
    b = points.astype(float) + 0.5
    length = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2).max()
    t = np.arange(0.0, 1.0, step / max(length, 1e-9))
    shape = np.array(cells.shape)
    for lo in range(0, len(a), chunk):
        va = a[lo:lo + chunk]
        pos = va[:, None, None, :] + (b[None, :, None, :] - va[:, None, None, :]) * t[None, None, :, None]
        idx = np.clip(np.floor(pos).astype(int), 0, shape - 1)
        own = (idx == points[None, :, None, :]).all(axis=-1)
        free = cells[idx[..., 0], idx[..., 1]] == FREE
        vis[lo:lo + chunk] = (free | own).all(axis=2)
    return vis


def organise(surface: np.ndarray, first_image: np.ndarray) -> np.ndarray:
    """Order surface points as a chain from an extreme point of the first image, going into it.

    Neighbours are 8-connected; where the chain breaks (sharp or thin shapes, which the thesis
    names as its weakness) the walk jumps to the nearest point not yet organised.

    Parameters
    ----------
    surface : (n, 2) int
        Surface cells.
    first_image : (m,) int
        Indices of the surface cells the first viewpoint sees.

    Returns
    -------
    (n,) int
        The order of the surface cells.
    """
    n = len(surface)
    tree = cKDTree(surface)
    pairs = tree.query_pairs(1.5, output_type="ndarray")
    neighbours = [[] for _ in range(n)]
    for i, j in pairs:
        neighbours[i].append(j)
        neighbours[j].append(i)
    in_image = np.zeros(n, dtype=bool)
    in_image[first_image] = True
    ends = [i for i in np.flatnonzero(in_image) if sum(in_image[j] for j in neighbours[i]) == 1]
    start = ends[0] if ends else (int(np.flatnonzero(in_image)[0]) if in_image.any() else 0)
    order = [start]
    done = np.zeros(n, dtype=bool)
    done[start] = True
    current = start
    while len(order) < n:
        options = [j for j in neighbours[current] if not done[j]]
        if options:
            def rank(j):
                orthogonal = np.abs(surface[j] - surface[current]).sum() == 1
                into_image = len(order) == 1 and in_image[j]
                free_next = sum(not done[k] for k in neighbours[j])
                return (not into_image, not orthogonal, free_next)
            current = min(options, key=rank)
        else:
            rest = np.flatnonzero(~done)
            current = int(rest[np.argmin(np.linalg.norm(surface[rest] - surface[current], axis=1))])
        done[current] = True
        order.append(current)
    return np.array(order)


def _angle_diff(a, b):
    return np.abs((a - b + np.pi) % (2 * np.pi) - np.pi)


def view_plan(cells: np.ndarray, d_opt: float, d_sec: float, hfov_deg: float, initial,
              range_capped: bool = False, region: np.ndarray | None = None,
              facing_free_only: bool = False) -> Viewpoints:
    """Viewpoints covering a 2D grid's target surface twice, by the thesis's procedure.

    ``initial`` is the initial point (cell coordinates, may be fractional). With
    ``range_capped`` a viewpoint only sees points within d_opt (docs/design.md's rule); the
    thesis's own rule has no range limit. ``region`` replaces the shot region (a bool grid).
    ``facing_free_only`` keeps only surface points next to free cells (a terrace's edge along
    the wall above it is seen from above, not from the side).

    Parameters
    ----------
    cells : (nx, ny) int8
        A 2D grid's cells.
    d_opt, d_sec : float
        Optimal and security distances, in cells.
    hfov_deg : float
        Horizontal field of view.
    initial : (2,) float
        The initial point.
    range_capped : bool
        A viewpoint sees only points within d_opt.
    region : (nx, ny) bool, optional
        Replaces the shot region.
    facing_free_only : bool
        Keep only surface points next to free cells.

    Returns
    -------
    Viewpoints
        The viewpoints and what they see.
    """
    sr = shot_region(cells, d_opt, d_sec) if region is None else region
    surface = surface_cells(cells, FREE if facing_free_only else None)
    empty = Viewpoints(np.zeros((0, 2), int), np.zeros(0), surface, np.zeros(len(surface), int))
    if len(surface) == 0:
        empty.failure = "no target surface in this slice"
        return empty
    candidates = np.argwhere(sr)
    if len(candidates) == 0:
        empty.failure = "the shot region is empty (security distance too large for d_opt, or no room)"
        return empty
    half = np.radians(hfov_deg) / 2
    los = line_of_sight(cells, candidates, surface)
    delta = (surface[None, :, :] - candidates[:, None, :]).astype(float)
    theta = np.arctan2(delta[..., 1], delta[..., 0])
    dist = np.linalg.norm(delta, axis=2)
    if range_capped:
        los &= dist <= d_opt

    def seen_by(v_idx: np.ndarray, p: int) -> np.ndarray:
        """(k, n): what each candidate sees when it looks at surface point p."""
        yaw = theta[v_idx, p][:, None]
        return los[v_idx] & (_angle_diff(theta[v_idx], yaw) <= half)

    # The initial path goes to the closest shot-region cell: the first shot, looking at the
    # nearest surface point it can see.
    start = np.asarray(initial, dtype=float)
    first = int(np.argmin(np.linalg.norm(candidates + 0.5 - start, axis=1)))
    visible = np.flatnonzero(los[first])
    if len(visible) == 0:
        empty.failure = "the first viewpoint sees no surface point"
        return empty
    look = int(visible[np.argmin(dist[first, visible])])
    count = np.zeros(len(surface), dtype=int)
    first_seen = seen_by(np.array([first]), look)[0]
    count += first_seen
    chosen, yaws, loops = [first], [theta[first, look]], [0]
    order = organise(surface, np.flatnonzero(first_seen))
    allowed = np.ones(len(candidates), dtype=bool)
    for loop, wanted in ((1, 0), (2, 1)):
        if loop == 2:  # bar the area around first-loop viewpoints (and the first shot)
            for v in chosen:
                near = np.abs(candidates - candidates[v]).max(axis=1) <= BAR_RADIUS
                allowed &= ~near
        for p in order:
            if count[p] != wanted:
                continue
            options = np.flatnonzero(los[:, p] & allowed)
            if len(options) == 0:
                options = np.flatnonzero(los[:, p])  # only barred cells see it: use them after all
            if len(options) == 0:
                return Viewpoints(candidates[chosen], np.array(yaws), surface[order], count[order],
                                  f"surface point {tuple(int(c) for c in surface[p])} cannot be seen from "
                                  "the shot region", loops)
            views = seen_by(options, p)
            score = (views & (count == wanted)[None, :]).sum(axis=1)
            best = score == score.max()
            previous = candidates[chosen[-1]]
            far = np.linalg.norm(candidates[options] - previous, axis=1)
            pick = np.flatnonzero(best)[np.argmax(far[best])]
            count += views[pick]
            chosen.append(int(options[pick]))
            yaws.append(theta[options[pick], p])
            loops.append(loop)
    arranged = arrange(candidates[chosen])
    return Viewpoints(candidates[chosen][arranged], np.array(yaws)[arranged], surface[order], count[order],
                      None, [loops[k] for k in arranged])


def arrange(cells: np.ndarray) -> np.ndarray:
    """Order viewpoints by proximity to the previous one, starting with the first shot.

    Parameters
    ----------
    cells : (k, 2) int
        Viewpoint cells.

    Returns
    -------
    (k,) int
        Their order.
    """
    n = len(cells)
    order = [0]
    left = np.ones(n, dtype=bool)
    left[0] = False
    for _ in range(n - 1):
        rest = np.flatnonzero(left)
        k = int(rest[np.argmin(np.linalg.norm(cells[rest] - cells[order[-1]], axis=1))])
        order.append(k)
        left[k] = False
    return np.array(order)
