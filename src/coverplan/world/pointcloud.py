"""Point clouds as obstacles: the occupied voxels of a LiDAR or photogrammetry cloud (trees,
wires, anything the mesh lacks) as a closed mesh the clearance and occlusion tests use.

A point marks its whole voxel occupied, so the obstacle contains every kept point: a route
that keeps the security distance from the voxel mesh keeps it from every point too. The mesh
is the voxels' outer faces only (faces between two occupied voxels are left out). LAS/LAZ are
read with laspy in chunks, so a cloud of tens of millions of points never sits in memory
whole; PLY point clouds through trimesh.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh
from scipy import ndimage

from coverplan.errors import InputFileError, ParameterError

# ASPRS LAS classes left out by default: ground (2), low noise (7), high noise (18).
DEFAULT_SKIPPED = (2, 7, 18)
CHUNK = 2_000_000
_FACES = [  # per direction: the 4 corner offsets of the face, counter-clockwise seen from outside
    ((1, 0, 0), [(1, 0, 0), (1, 1, 0), (1, 1, 1), (1, 0, 1)]),
    ((-1, 0, 0), [(0, 0, 0), (0, 0, 1), (0, 1, 1), (0, 1, 0)]),
    ((0, 1, 0), [(0, 1, 0), (0, 1, 1), (1, 1, 1), (1, 1, 0)]),
    ((0, -1, 0), [(0, 0, 0), (1, 0, 0), (1, 0, 1), (0, 0, 1)]),
    ((0, 0, 1), [(0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]),
    ((0, 0, -1), [(0, 0, 0), (0, 1, 0), (1, 1, 0), (1, 0, 0)]),
]


def parse_classes(text: str | None):
    """'3,4,5' -> (3, 4, 5); None -> None (every class but ground and noise).

    Parameters
    ----------
    text : str or None
        Comma-separated ASPRS class numbers.

    Returns
    -------
    tuple of int or None
        The classes kept.

    Raises
    ------
    ParameterError
        When an item is not a class number.
    """
    if text is None:
        return None
    try:
        classes = tuple(int(v) for v in str(text).split(",") if v.strip())
    except ValueError:
        raise ParameterError(f"--point-classes takes LAS class numbers like 3,4,5,14; got {text!r}") from None
    if not classes or any(not 0 <= c <= 255 for c in classes):
        raise ParameterError(f"--point-classes takes LAS class numbers 0-255, got {text!r}")
    return classes


def _keep(classification, classes) -> np.ndarray:
    if classes is None:
        return ~np.isin(classification, DEFAULT_SKIPPED)
    return np.isin(classification, classes)


def voxel_keys(path, resolution: float, classes=None) -> tuple[np.ndarray, int, int]:
    """Integer voxel indices (n, 3) occupied by the kept points; also points read and kept.

    Parameters
    ----------
    path : str or Path
        A LAS or LAZ file.
    resolution : float
        The voxel size, metres.
    classes : tuple of int, optional
        The classes kept.

    Returns
    -------
    keys : (n, 3) int
        Occupied voxels.
    read, kept : int
        Points read and points kept.
    """
    path = Path(path)
    ext = path.suffix.lower()
    chunks, read, kept = [], 0, 0
    if ext in (".las", ".laz"):
        try:
            import laspy
        except ImportError:
            raise ParameterError("reading LAS/LAZ point clouds needs laspy: pip install 'coverplan[points]'") from None
        # The single-threaded LAZ decoder: the parallel one hangs in processes forked after it
        # ran (Dask workers, process pools).
        backend = laspy.LazBackend.Lazrs if laspy.LazBackend.Lazrs in laspy.LazBackend.detect_available() else None
        try:
            with laspy.open(path, laz_backend=backend) as reader:
                for chunk in reader.chunk_iterator(CHUNK):
                    xyz = np.column_stack([np.asarray(chunk.x), np.asarray(chunk.y), np.asarray(chunk.z)])
                    keep = _keep(np.asarray(chunk.classification), classes)
                    _check_finite(path, xyz[keep])
                    read += len(xyz)
                    kept += int(keep.sum())
                    chunks.append(np.unique(np.floor(xyz[keep] / resolution).astype(np.int64), axis=0))
        except (laspy.errors.LaspyException, ValueError, OSError) as exc:
            raise InputFileError(path, f"cannot be read as a LAS/LAZ point cloud ({str(exc).splitlines()[0][:120]})") \
                from None
    elif ext == ".ply":
        try:
            cloud = trimesh.load(str(path), process=False)
        except Exception as exc:  # trimesh raises many types on malformed files
            raise InputFileError(path, f"cannot be read as a PLY point cloud ({str(exc)[:120]})") from None
        xyz = np.asarray(getattr(cloud, "vertices", np.zeros((0, 3))), dtype=float)
        if classes is not None:
            raise ParameterError(f"{path.name} has no point classes; leave out --point-classes")
        read = kept = len(xyz)
        _check_finite(path, xyz)
        chunks.append(np.unique(np.floor(xyz / resolution).astype(np.int64), axis=0))
    else:
        raise InputFileError(path, "is not a point cloud; give a .las, .laz or .ply file")
    if kept == 0:
        which = "every class but ground and noise" if classes is None else f"classes {','.join(map(str, classes))}"
        raise InputFileError(path, f"has no points of {which} ({read:,} points read)")
    return np.unique(np.concatenate(chunks), axis=0), read, kept


def _check_finite(path, xyz) -> None:
    if not np.isfinite(xyz).all():
        raise InputFileError(path, "has points with NaN or infinite coordinates")


MAX_CELLS = 4e8  # bytes of the occupancy grid, one per cell


def _close_edge_contacts(occupied: np.ndarray) -> int:
    """Fill a voxel wherever two occupied voxels touch only along an edge, so that every edge of
    the surface joins exactly two faces (a manifold mesh). The obstacle only grows."""
    added = 0
    for _round in range(20):
        changed = 0
        for i, j in ((0, 1), (0, 2), (1, 2)):
            for sign in (1, -1):
                d = np.zeros(3, dtype=int)
                d[i], d[j] = 1, sign
                ei, ej = np.eye(3, dtype=int)[i], sign * np.eye(3, dtype=int)[j]
                # Shifting by -k puts cell v + k at v (the grid's empty rim absorbs the wrap).
                other = np.roll(occupied, tuple(-d), axis=(0, 1, 2))
                side_i = np.roll(occupied, tuple(-ei), axis=(0, 1, 2))
                side_j = np.roll(occupied, tuple(-ej), axis=(0, 1, 2))
                need = occupied & other & ~side_i & ~side_j
                if need.any():
                    cells = np.argwhere(need) + ei
                    occupied[tuple(cells.T)] = True
                    changed += len(cells)
        added += changed
        if not changed:
            return added
    return added


def voxel_mesh(keys: np.ndarray, resolution: float) -> trimesh.Trimesh:
    """The outer faces of the voxels ``keys`` (integer indices), as a closed, outward, manifold
    mesh in metres (voxels touching only along an edge are joined first, enclosed hollows filled).

    Parameters
    ----------
    keys : (n, 3) int
        Occupied voxels.
    resolution : float
        The voxel size, metres.

    Returns
    -------
    trimesh.Trimesh
        The closed mesh.
    """
    keys = np.asarray(keys, dtype=np.int64).reshape(-1, 3)
    lo = keys.min(axis=0) - 1
    dims = keys.max(axis=0) - lo + 2  # an empty rim of one cell all round
    if float(np.prod(dims)) > MAX_CELLS:
        raise ParameterError(f"the point clouds span {' x '.join(str(int(v)) for v in dims)} voxels of "
                             f"{resolution:g} m; raise --points-resolution or crop the clouds to the site")
    occupied = np.zeros(tuple(dims), dtype=bool)
    occupied[tuple((keys - lo).T)] = True
    _close_edge_contacts(occupied)
    # Hollows no drone can enter (inside a crown's shell of points) become solid: no inner
    # surfaces, and the obstacle only grows.
    occupied = ndimage.binary_fill_holes(occupied)
    cells = np.argwhere(occupied)
    quads = []
    for step, corners in _FACES:
        nb = cells + step
        open_side = ~occupied[tuple(nb.T)]
        quads.append(cells[open_side][:, None, :] + np.array(corners)[None, :, :])
    quads = np.concatenate(quads)  # (faces, 4, 3) integer corners
    corners, inverse = np.unique(quads.reshape(-1, 3), axis=0, return_inverse=True)
    q = inverse.reshape(-1, 4)
    faces = np.vstack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    return trimesh.Trimesh(vertices=(corners + lo).astype(float) * resolution, faces=faces, process=False)


def point_obstacle(path, resolution: float = 0.5, classes=None) -> tuple[trimesh.Trimesh, str]:
    """The cloud's occupied voxels as a mesh, and a note saying what was kept.

    Parameters
    ----------
    path : str or Path
        A LAS or LAZ file.
    resolution : float
        The voxel size, metres.
    classes : tuple of int, optional
        The classes kept.

    Returns
    -------
    mesh : trimesh.Trimesh
        The obstacle.
    note : str
        What was read and kept.
    """
    if not (np.isfinite(resolution) and resolution > 0):
        raise ParameterError(f"--points-resolution must be a positive number, got {resolution!r}")
    path = Path(path)
    if not path.exists():
        raise InputFileError(path, "no such file")
    keys, read, kept = voxel_keys(path, float(resolution), classes)
    mesh = voxel_mesh(keys, float(resolution))
    note = (f"{path.name}: {kept:,} of {read:,} points kept as obstacles, {len(keys):,} voxels of "
            f"{resolution:g} m ({len(mesh.faces):,} triangles)")
    return mesh, note
