"""The thesis's Scene Grid: a 2D or 3D array of free / target / obstacle cells.

Rasterisers build one from 2D shapely polygons or from the meshes of a Scene, so the voxel
baseline and the mesh planner read the same scene. Cell (i, j[, k]) covers
``origin + [i, j, k] * cell`` to ``origin + [i+1, j+1, k+1] * cell``; its centre is the point
the thesis's planner places the drone at.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

FREE, TARGET, OBSTACLE = 0, 1, 2


@dataclass
class SceneGrid:
    """Cell values (FREE / TARGET / OBSTACLE), cell size in metres and the grid's origin.

    Parameters
    ----------
    cells : (nx, ny) or (nx, ny, nz) int8
        FREE, TARGET or OBSTACLE per cell.
    cell : float
        The cell size, metres.
    origin : (3,) float
        The grid's lower corner in the local frame.
    """

    cells: np.ndarray
    cell: float
    origin: np.ndarray  # metres, the corner of cell 0

    @property
    def ndim(self) -> int:
        """2 or 3."""
        return self.cells.ndim

    @property
    def shape(self) -> tuple:
        """The cells' shape."""
        return self.cells.shape

    def centres(self, index) -> np.ndarray:
        """Metric centres of cells given as (n, ndim) integer indices.

        Parameters
        ----------
        index : (n, ndim) int
            Cell indices.

        Returns
        -------
        (n, ndim) float
            Metres.
        """
        return self.origin[: self.ndim] + (np.asarray(index, dtype=float) + 0.5) * self.cell

    def index_of(self, points) -> np.ndarray:
        """Cell indices of metric points (clipped to the grid).

        Parameters
        ----------
        points : (n, ndim) float
            Metres in the local frame.

        Returns
        -------
        (n, ndim) int
            Cell indices.
        """
        idx = np.floor((np.asarray(points, dtype=float)[..., : self.ndim] - self.origin[: self.ndim]) / self.cell)
        return np.clip(idx.astype(int), 0, np.array(self.shape) - 1)

    def slice_at(self, z: float) -> "SceneGrid":
        """The 2D grid of the layer containing height ``z`` (3D grids only).

        Parameters
        ----------
        z : float
            A height, metres.

        Returns
        -------
        SceneGrid
            A 2D grid.
        """
        k = int(np.clip(np.floor((z - self.origin[2]) / self.cell), 0, self.shape[2] - 1))
        return SceneGrid(self.cells[:, :, k].copy(), self.cell, self.origin.copy())


def grid_from_polygons(targets, obstacles=(), size: int = 50, cell: float = 1.0, origin=(0.0, 0.0)) -> SceneGrid:
    """2D grid of ``size`` x ``size`` cells: a cell is target/obstacle when its centre is inside.

    Parameters
    ----------
    targets : sequence of shapely.Polygon
        The target's outlines.
    obstacles : sequence of shapely.Polygon
        Obstacles' outlines.
    size : int
        Cells along each side.
    cell : float
        The cell size, metres.
    origin : (float, float)
        The grid's lower-left corner.

    Returns
    -------
    SceneGrid
        A 2D grid.
    """
    idx = np.stack(np.meshgrid(np.arange(size), np.arange(size), indexing="ij"), axis=-1).reshape(-1, 2)
    centre = np.asarray(origin, float) + (idx + 0.5) * cell
    cells = np.full(size * size, FREE, dtype=np.int8)
    for value, polys in ((OBSTACLE, obstacles), (TARGET, targets)):
        for poly in polys:
            cells[shapely.contains_xy(poly, centre[:, 0], centre[:, 1])] = value
    return SceneGrid(cells.reshape(size, size), float(cell), np.array([*origin, 0.0], dtype=float))


def grid_from_scene(scene, cell: float, margin: float, ground: float | None = None) -> SceneGrid:
    """3D grid around the scene's target (plus ``margin`` metres): cells whose centre lies
    inside a target mesh are target, inside an obstacle mesh obstacle.

    Parameters
    ----------
    scene : Scene
        The scene rasterised.
    cell : float
        The cell size, metres.
    margin : float
        Metres of free space around the target.
    ground : float, optional
        The grid's floor; the scene's ground when None.

    Returns
    -------
    SceneGrid
        A 3D grid.
    """
    lo, hi = scene.bounds("target")
    ground = scene.ground_z if ground is None else ground
    lo = np.array([lo[0] - margin, lo[1] - margin, ground])
    hi = np.array([hi[0] + margin, hi[1] + margin, hi[2] + margin])
    shape = np.ceil((hi - lo) / cell).astype(int)
    idx = np.stack(np.meshgrid(*[np.arange(s) for s in shape], indexing="ij"), axis=-1).reshape(-1, 3)
    centre = lo + (idx + 0.5) * cell
    inside = scene.rays.inside_each(centre)
    cells = np.full(len(centre), FREE, dtype=np.int8)
    for i, part in enumerate(scene.parts):
        cells[inside[:, i] & (cells == FREE)] = TARGET if part.role == "target" else OBSTACLE
    return SceneGrid(cells.reshape(tuple(shape)), float(cell), lo)
