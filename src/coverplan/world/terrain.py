"""Terrain: the ground under the flight as a height grid in the scene's local frame.

The ground is the grid's triangulated surface: every cell split along the diagonal from its
(+x, 0) corner to its (0, +y) corner, heights linear on each triangle, and beyond the grid the
height of its nearest edge. Because the surface is piecewise linear, a straight segment's
height above it is piecewise linear too, with breaks only where the segment crosses a grid
line or a diagonal; checking those crossings and the ends is an exact test of "every point of
the segment is at least the minimum altitude above the ground".

Sources: a DTM raster (GeoTIFF through rasterio, reprojected to the scene's CRS) or the
ground surfaces of a city model (TINRelief, roads, land use), read into a grid by vertical
rays. Cells without data take the height of the nearest cell with data.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import trimesh
from scipy import ndimage

from coverplan.errors import InputFileError, ParameterError
from coverplan.geometry.raycast import RayCaster
from coverplan.runs import run_offsets

# The grid is kept below this many cells: a finer raster is resampled, keeping each new
# cell's highest ground (the minimum altitude is then never measured from too low).
MAX_CELLS = 4_000_000


@dataclass
class Terrain:
    """Ground heights (m, local frame) at grid nodes x0 + i*dx, y0 + j*dy: ``heights[j, i]``.

    Parameters
    ----------
    x0, y0 : float
        The first node, metres.
    dx, dy : float
        Node spacing, metres.
    heights : (ny, nx) float
        Ground heights, metres.
    source : str
        Where they come from.
    """

    x0: float
    y0: float
    dx: float
    dy: float
    heights: np.ndarray
    source: str = "terrain"

    def __post_init__(self):
        self.heights = np.asarray(self.heights, dtype=float)
        if self.heights.ndim != 2 or min(self.heights.shape) < 2:
            raise ParameterError(f"{self.source}: a terrain needs at least 2 x 2 heights")
        if not np.isfinite(self.heights).all():
            raise ParameterError(f"{self.source}: the terrain has cells without a height")
        if not (self.dx > 0 and self.dy > 0):
            raise ParameterError(f"{self.source}: terrain cells must have a positive size")

    @property
    def shape(self) -> tuple[int, int]:
        """(ny, nx): the grid's nodes."""
        return self.heights.shape

    def _grid_coords(self, xy):
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        return (xy[:, 0] - self.x0) / self.dx, (xy[:, 1] - self.y0) / self.dy

    def _height_uv(self, u, v) -> np.ndarray:
        ny, nx = self.shape
        u, v = np.clip(u, 0.0, nx - 1), np.clip(v, 0.0, ny - 1)
        i = np.minimum(np.floor(u).astype(np.int64), nx - 2)
        j = np.minimum(np.floor(v).astype(np.int64), ny - 2)
        fu, fv = u - i, v - j
        h = self.heights
        h00, h10, h01, h11 = h[j, i], h[j, i + 1], h[j + 1, i], h[j + 1, i + 1]
        lower = fu + fv <= 1.0
        return np.where(lower, h00 + fu * (h10 - h00) + fv * (h01 - h00),
                        h11 + (1.0 - fu) * (h01 - h11) + (1.0 - fv) * (h10 - h11))

    def height(self, xy) -> np.ndarray:
        """Ground height under each (x, y).

        Parameters
        ----------
        xy : (n, 2) float
            Local coordinates.

        Returns
        -------
        (n,) float
            Metres, interpolated on the grid's triangles.
        """
        return self._height_uv(*self._grid_coords(xy))

    def lowest_in(self, lo_xy, hi_xy) -> float:
        """Lowest ground over the box [lo_xy, hi_xy] (clamped to the grid like ``height``).

        Parameters
        ----------
        lo_xy, hi_xy : (2,) float
            The box's corners.

        Returns
        -------
        float
            Metres.
        """
        return float(self._block(lo_xy, hi_xy).min())

    def highest_in(self, lo_xy, hi_xy) -> float:
        """Highest ground over the box [lo_xy, hi_xy] (clamped to the grid like ``height``).

        Parameters
        ----------
        lo_xy, hi_xy : (2,) float
            The box's corners.

        Returns
        -------
        float
            Metres.
        """
        return float(self._block(lo_xy, hi_xy).max())

    def _block(self, lo_xy, hi_xy) -> np.ndarray:
        """The grid nodes of the cells the box [lo_xy, hi_xy] touches."""
        ny, nx = self.shape
        (u0, u1), (v0, v1) = (self._grid_coords(np.array([lo_xy, hi_xy])[:, :2]))
        i0, i1 = int(np.clip(np.floor(u0), 0, nx - 1)), int(np.clip(np.ceil(u1), 0, nx - 1))
        j0, j1 = int(np.clip(np.floor(v0), 0, ny - 1)), int(np.clip(np.ceil(v1), 0, ny - 1))
        return self.heights[j0:j1 + 1, i0:i1 + 1]

    @cached_property
    def max_slope(self) -> float:
        """Largest rise per metre of horizontal travel over any triangle (bounds the height
        change along a segment: ``abs(dh) <= max_slope * horizontal length``)."""
        h = self.heights
        gx = np.abs(np.diff(h, axis=1)) / self.dx
        gy = np.abs(np.diff(h, axis=0)) / self.dy
        # On a triangle the gradient is (dh/dx, dh/dy) from two of its edges; its norm is below
        # the norm of the largest edge slopes.
        return float(np.hypot(gx.max(), gy.max()))

    @cached_property
    def mesh(self) -> trimesh.Trimesh:
        """The ground surface, facing up, over the grid."""
        ny, nx = self.shape
        return self._mesh_through(np.arange(nx), np.arange(ny))

    def _mesh_through(self, cols, rows) -> trimesh.Trimesh:
        """Two triangles per cell of the grid through the given node columns and rows."""
        gx, gy = np.meshgrid(self.x0 + cols * self.dx, self.y0 + rows * self.dy)
        vertices = np.column_stack([gx.ravel(), gy.ravel(), self.heights[np.ix_(rows, cols)].ravel()])
        idx = np.arange(len(rows) * len(cols)).reshape(len(rows), len(cols))
        a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
        faces = np.vstack([np.column_stack([a, b, c]), np.column_stack([b, d, c])])
        return trimesh.Trimesh(vertices, faces, process=False)

    def mesh_within(self, lo_xy, hi_xy, max_cells: int | None = 40_000) -> trimesh.Trimesh:
        """The ground over the box ``lo_xy``-``hi_xy`` (and one node beyond) through every k-th
        grid node, k such that at most about ``max_cells`` cells remain (for pictures; None:
        every node, the ground exactly).

        Parameters
        ----------
        lo_xy, hi_xy : (2,) float
            The box's corners.
        max_cells : int or None
            The most cells kept.

        Returns
        -------
        trimesh.Trimesh
            The ground's surface.
        """
        ny, nx = self.shape
        u, v = self._grid_coords(np.array([lo_xy[:2], hi_xy[:2]], dtype=float))
        i0, i1 = int(np.clip(np.floor(u[0]) - 1, 0, nx - 2)), int(np.clip(np.ceil(u[1]) + 1, 1, nx - 1))
        j0, j1 = int(np.clip(np.floor(v[0]) - 1, 0, ny - 2)), int(np.clip(np.ceil(v[1]) + 1, 1, ny - 1))
        step = 1 if max_cells is None else max(1, int(np.ceil(np.sqrt(max(i1 - i0, 1) * max(j1 - j0, 1) / max_cells))))
        cols = np.unique(np.append(np.arange(i0, i1 + 1, step), i1))  # the box's edge kept
        rows = np.unique(np.append(np.arange(j0, j1 + 1, step), j1))
        return self._mesh_through(cols, rows)

    def clearance_envelope(self, distance: float) -> "Terrain":
        """The lowest heights ``distance`` clear of this ground in 3D, as a terrain of its grid.

        A point on or above it is at least ``distance`` from every point of the ground's
        surface, slopes and ridges included (a drone flying ``distance`` above a 40 deg bank
        is only 0.77 ``distance`` from it). Built as a dilation of each cell's highest corner
        by the ball's upper half, then each node the highest of its cells: on or above the true
        envelope everywhere, by up to about a cell's rise; over flat ground exactly ``distance``
        above it. Cached per distance.

        Parameters
        ----------
        distance : float
            Metres.

        Returns
        -------
        Terrain
            On the same grid.
        """
        cache = self.__dict__.setdefault("_envelopes", {})
        key = round(float(distance), 9)
        if key not in cache:
            h = self.heights
            cell_top = np.maximum.reduce([h[:-1, :-1], h[:-1, 1:], h[1:, :-1], h[1:, 1:]])
            reach_i, reach_j = int(np.ceil(distance / self.dx)) + 1, int(np.ceil(distance / self.dy)) + 1
            gap_x = np.maximum(np.abs(np.arange(-reach_i, reach_i + 1)) - 1, 0) * self.dx  # cell to cell
            gap_y = np.maximum(np.abs(np.arange(-reach_j, reach_j + 1)) - 1, 0) * self.dy
            gap = np.hypot(gap_y[:, None], gap_x[None, :])
            within = gap <= distance
            cap = np.sqrt(np.maximum(distance ** 2 - gap ** 2, 0.0))
            top = ndimage.grey_dilation(cell_top, footprint=within, structure=np.where(within, cap, 0.0),
                                        mode="nearest")
            padded = np.pad(top, 1, mode="edge")
            nodes = np.maximum.reduce([padded[:-1, :-1], padded[:-1, 1:], padded[1:, :-1], padded[1:, 1:]])
            cache[key] = Terrain(self.x0, self.y0, self.dx, self.dy, nodes,
                                 f"{self.source}, {distance:g} m clear in 3D")
        return cache[key]

    def segments_above(self, starts, ends, altitude: float, tol: float = 1e-6,
                       max_checks: int = 4_000_000) -> np.ndarray:
        """Whether every point of each segment is at least ``altitude`` above the ground
        (exact for this piecewise-linear ground, up to ``tol``).

        Parameters
        ----------
        starts, ends : (n, 3) float
            The segments.
        altitude : float
            Metres.
        tol : float
            Metres.
        max_checks : int
            Crossings tested per batch.

        Returns
        -------
        (n,) bool
            Segments that keep the altitude.
        """
        a = np.asarray(starts, dtype=float).reshape(-1, 3)
        b = np.asarray(ends, dtype=float).reshape(-1, 3)
        if not len(a):
            return np.ones(0, dtype=bool)
        # Settled by the ends: both high enough that no slope of this ground reaches up to the
        # segment in between (the height changes at most max_slope per metre).
        margin = np.minimum(a[:, 2] - self.height(a[:, :2]), b[:, 2] - self.height(b[:, :2])) - altitude
        horizontal = np.linalg.norm(b[:, :2] - a[:, :2], axis=1)
        sure = margin >= self.max_slope * horizontal
        ok = margin >= -tol
        unsure = np.flatnonzero(ok & ~sure)
        if len(unsure):
            ok[unsure] = self.lowest_above(a[unsure], b[unsure], max_checks) >= altitude - tol
        return ok

    def lowest_above(self, starts, ends, max_checks: int = 4_000_000) -> np.ndarray:
        """Each segment's lowest height above the ground (exact: at its ends or where it crosses
        a grid line or a cell's diagonal).

        Parameters
        ----------
        starts, ends : (n, 3) float
            The segments.
        max_checks : int
            Crossings tested per batch.

        Returns
        -------
        (n,) float
            Metres.
        """
        return self._extreme_above(starts, ends, np.minimum, np.inf, max_checks)

    def highest_above(self, starts, ends, max_checks: int = 4_000_000) -> np.ndarray:
        """Each segment's greatest height above the ground (exact, as ``lowest_above``).

        Parameters
        ----------
        starts, ends : (n, 3) float
            The segments.
        max_checks : int
            Crossings tested per batch.

        Returns
        -------
        (n,) float
            Metres.
        """
        return self._extreme_above(starts, ends, np.maximum, -np.inf, max_checks)

    def _extreme_above(self, starts, ends, pick, empty: float, max_checks: int) -> np.ndarray:
        a = np.asarray(starts, dtype=float).reshape(-1, 3)
        b = np.asarray(ends, dtype=float).reshape(-1, 3)
        out = np.empty(len(a))
        u0, v0 = self._grid_coords(a[:, :2])
        u1, v1 = self._grid_coords(b[:, :2])
        work = 5 + np.abs(u1 - u0) + np.abs(v1 - v0) + np.abs(u1 + v1 - u0 - v0)  # ends + crossings, roughly
        first = 0
        while first < len(a):  # chunks of about max_checks points
            last = first + max(1, int(np.searchsorted(np.cumsum(work[first:]), max_checks)))
            owner, t = self._breakpoints(u0[first:last], v0[first:last], u1[first:last], v1[first:last])
            p = a[first:last][owner] + t[:, None] * (b[first:last] - a[first:last])[owner]
            above = p[:, 2] - self.height(p[:, :2])
            extreme = np.full(last - first, empty)
            pick.at(extreme, owner, above)
            out[first:last] = extreme
            first = last
        return out

    def _breakpoints(self, u0, v0, u1, v1) -> tuple[np.ndarray, np.ndarray]:
        """(segment, t) of the ends and of every crossing of a grid line or diagonal."""
        ny, nx = self.shape
        n = len(u0)
        seg, ts = [np.arange(n), np.arange(n)], [np.zeros(n), np.ones(n)]
        # Beyond the grid the height is the edge's: only crossings within it break the line.
        for s0, s1, top in ((u0, u1, nx - 1), (v0, v1, ny - 1), (u0 + v0, u1 + v1, nx + ny - 2)):
            lo = np.maximum(np.ceil(np.minimum(s0, s1)), 0.0)
            hi = np.minimum(np.floor(np.maximum(s0, s1)), top)
            count = np.maximum(hi - lo + 1, 0).astype(np.int64)
            total = int(count.sum())
            if not total:
                continue
            owner = np.repeat(np.arange(n), count)
            k = lo[owner] + run_offsets(count)
            ds = (s1 - s0)[owner]
            moving = np.abs(ds) > 1e-12
            t = np.where(moving, (k - s0[owner]) / np.where(moving, ds, 1.0), 0.0)
            seg.append(owner)
            ts.append(np.clip(t, 0.0, 1.0))
        return np.concatenate(seg), np.concatenate(ts)

    @classmethod
    def from_triangles(cls, triangles, lo_xy, hi_xy, step: float, source: str) -> "Terrain":
        """Heights of the highest of ``triangles`` over a grid on [lo_xy, hi_xy]; nodes no
        triangle covers take the nearest covered node's height.

        Parameters
        ----------
        triangles : (m, 3, 3) float
            The ground's triangles.
        lo_xy, hi_xy : (2,) float
            The grid's corners.
        step : float
            Node spacing, metres.
        source : str
            Where the triangles come from.

        Returns
        -------
        Terrain
            The grid.
        """
        tri = np.asarray(triangles, dtype=float).reshape(-1, 3, 3)
        if not len(tri):
            raise InputFileError(source, "holds no ground surfaces")
        xs, ys = _axis(lo_xy[0], hi_xy[0], step), _axis(lo_xy[1], hi_xy[1], step)
        if len(xs) * len(ys) > MAX_CELLS:
            step *= np.sqrt(len(xs) * len(ys) / MAX_CELLS)
            xs, ys = _axis(lo_xy[0], hi_xy[0], step), _axis(lo_xy[1], hi_xy[1], step)
        mesh = trimesh.Trimesh(tri.reshape(-1, 3), np.arange(3 * len(tri)).reshape(-1, 3), process=False)
        gx, gy = np.meshgrid(xs, ys)
        top = float(tri[:, :, 2].max()) + 10.0
        origins = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, top)])
        dist, _mesh, _face = RayCaster([mesh]).first_hit(origins, np.tile([0.0, 0.0, -1.0], (len(origins), 1)))
        heights = (top - dist).reshape(gx.shape)
        return cls(float(xs[0]), float(ys[0]), float(xs[1] - xs[0]), float(ys[1] - ys[0]),
                   fill_gaps(heights, source), source)


def _axis(lo: float, hi: float, step: float) -> np.ndarray:
    n = max(int(np.ceil((hi - lo) / step)) + 1, 2)
    return lo + np.arange(n) * ((hi - lo) / (n - 1) if hi > lo else step)


def fill_gaps(heights: np.ndarray, source: str) -> np.ndarray:
    """NaN cells take their nearest valid cell's height (under buildings, past a raster's edge).

    Parameters
    ----------
    heights : (ny, nx) float
        Heights with NaN where unknown.
    source : str
        The raster's name, for the error.

    Returns
    -------
    (ny, nx) float
        ``heights``, filled in place.

    Raises
    ------
    InputFileError
        When no cell around the target has a height.
    """
    from scipy import ndimage
    missing = ~np.isfinite(heights)
    if missing.all():
        raise InputFileError(source, "has no height anywhere around the target")
    if missing.any():
        _d, (jj, ii) = ndimage.distance_transform_edt(missing, return_indices=True)
        heights = heights[jj, ii]
    return heights
