"""Points covering a mesh's surface within a known radius, and the pieces the clearance queries are built from."""

from __future__ import annotations

import math

import fcl
import numpy as np


def _bvh(vertices, faces) -> fcl.CollisionObject:
    model = fcl.BVHModel()
    model.beginModel(len(vertices), len(faces))
    model.addSubModel(np.asarray(vertices, dtype=float), np.asarray(faces, dtype=np.int32))
    model.endModel()
    return fcl.CollisionObject(model, fcl.Transform())


def mesh_distance(a, b) -> float:
    """Smallest distance between two meshes' surfaces (0 when they touch or cross).

    Parameters
    ----------
    a, b : trimesh.Trimesh
        The meshes.

    Returns
    -------
    float
        Metres.
    """
    result = fcl.DistanceResult()
    d = fcl.distance(_bvh(a.vertices, a.faces), _bvh(b.vertices, b.faces), fcl.DistanceRequest(), result)
    return max(float(d), 0.0)


def surface_lattice(triangles, max_edge: float) -> np.ndarray:
    """Points on triangles such that every surface point is within max_edge/sqrt(3) of one.

    Each triangle is split into n^2 similar sub-triangles (n = ceil(longest edge / max_edge));
    the points are their corners (barycentric lattice), shared corners repeated.

    Parameters
    ----------
    triangles : (m, 3, 3) float
        Triangle corners.
    max_edge : float
        The longest sub-triangle edge, metres.

    Returns
    -------
    (n, 3) float
        The lattice points.
    """
    triangles = np.asarray(triangles, dtype=float).reshape(-1, 3, 3)
    edges = np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2).max(axis=1)
    splits = np.maximum(np.ceil(edges / max_edge), 1).astype(int)
    out = []
    for n in np.unique(splits):
        tri = triangles[splits == n]
        i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
        keep = i + j <= n
        u, v = i[keep] / n, j[keep] / n
        a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
        out.append((a[:, None] + u[None, :, None] * (b - a)[:, None] + v[None, :, None] * (c - a)[:, None])
                   .reshape(-1, 3))
    return np.vstack(out) if out else np.zeros((0, 3))


def surface_cover(mesh, max_edge: float) -> tuple[np.ndarray, float]:
    """Points on a mesh and a radius such that every surface point lies within the radius of one.

    The mesh's own vertices, plus a barycentric lattice on triangles longer than ``max_edge``;
    fine meshes (scans) thus cost no more points than they have vertices.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The mesh.
    max_edge : float
        The longest lattice edge, metres.

    Returns
    -------
    points : (n, 3) float
        Points on the surface.
    radius : float
        Every surface point lies within it of a point.
    """
    tri = mesh.triangles
    if len(tri) == 0:
        return np.zeros((0, 3)), 0.0
    edges = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    splits = np.maximum(np.ceil(edges / max_edge), 1)
    big = splits >= 2
    points = [np.asarray(mesh.vertices, dtype=float)]
    if big.any():
        points.append(surface_lattice(tri[big], max_edge))
    return np.vstack(points), float((edges / splits).max() / math.sqrt(3.0))


def rotations_z_to(directions) -> np.ndarray:
    """Rotation matrices (n, 3, 3) taking +z onto each unit vector in ``directions``.

    Parameters
    ----------
    directions : (n, 3) float
        Unit vectors.

    Returns
    -------
    (n, 3, 3) float
        Rotation matrices.
    """
    d = np.asarray(directions, dtype=float).reshape(-1, 3)
    v = np.column_stack([-d[:, 1], d[:, 0], np.zeros(len(d))])  # z x d
    c = d[:, 2]
    s2 = (v ** 2).sum(axis=1)
    vx = np.zeros((len(d), 3, 3))
    vx[:, 0, 1], vx[:, 0, 2] = -v[:, 2], v[:, 1]
    vx[:, 1, 0], vx[:, 1, 2] = v[:, 2], -v[:, 0]
    vx[:, 2, 0], vx[:, 2, 1] = -v[:, 1], v[:, 0]
    factor = np.where(s2 > 1e-24, (1.0 - c) / np.maximum(s2, 1e-300), 0.0)
    rot = np.eye(3)[None] + vx + np.einsum("nij,njk->nik", vx, vx) * factor[:, None, None]
    flip = (s2 <= 1e-24) & (c < 0)
    rot[flip] = np.diag([1.0, -1.0, -1.0])
    return rot
