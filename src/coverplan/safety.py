"""Clearance to the scene: exact FCL queries behind a vectorised KD-tree bound.

The KD-tree holds the vertices of every mesh subdivided so no edge is longer than
``cover_edge``; any surface point lies within ``cover_edge / sqrt(3)`` of one of them, so
``kd_distance - cover_radius <= true distance <= kd_distance``. Points whose answer the
bound cannot settle go to FCL (sphere collide for yes/no, distance for numbers).
FCL BVHs are hollow, so "is this point clear" also asks the ray caster whether the point
lies inside a mesh.
"""

from __future__ import annotations

import math

import fcl
import numpy as np
from scipy.spatial import cKDTree


def _bvh(vertices, faces) -> fcl.CollisionObject:
    model = fcl.BVHModel()
    model.beginModel(len(vertices), len(faces))
    model.addSubModel(np.asarray(vertices, dtype=float), np.asarray(faces, dtype=np.int32))
    model.endModel()
    return fcl.CollisionObject(model, fcl.Transform())


def surface_lattice(triangles, max_edge: float) -> np.ndarray:
    """Points on triangles such that every surface point is within max_edge/sqrt(3) of one.

    Each triangle is split into n^2 similar sub-triangles (n = ceil(longest edge / max_edge));
    the points are their corners (barycentric lattice), shared corners repeated.
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


def rotations_z_to(directions) -> np.ndarray:
    """Rotation matrices (n, 3, 3) taking +z onto each unit vector in ``directions``."""
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


class ClearanceModel:
    """Distances from points and segments to a list of meshes."""

    def __init__(self, meshes, rays=None, cover_edge: float | None = None):
        self.meshes = list(meshes)
        self.rays = rays
        vertices, faces, owner = [], [], []
        offset = 0
        for i, mesh in enumerate(self.meshes):
            vertices.append(mesh.vertices)
            faces.append(mesh.faces + offset)
            offset += len(mesh.vertices)
            owner.append(np.full(len(mesh.faces), i))
        self._vertices = np.vstack(vertices) if vertices else np.zeros((0, 3))
        self._faces = np.vstack(faces) if faces else np.zeros((0, 3), dtype=np.int64)
        self._face_owner = np.concatenate(owner) if owner else np.zeros(0, dtype=np.int64)
        if cover_edge is None:
            extent = np.ptp(self._vertices, axis=0).max() if len(self._vertices) else 1.0
            cover_edge = max(extent / 200.0, 0.05)
        self.cover_edge = float(cover_edge)
        self.cover_radius = self.cover_edge / math.sqrt(3.0) * 1.001
        dense_v, dense_owner = [], []
        for i, mesh in enumerate(self.meshes):
            v = surface_lattice(mesh.triangles, self.cover_edge)
            dense_v.append(v)
            dense_owner.append(np.full(len(v), i))
        self._tree = cKDTree(np.vstack(dense_v)) if dense_v else None
        self._tree_owner = np.concatenate(dense_owner) if dense_owner else np.zeros(0, np.int64)
        self._all = _bvh(self._vertices, self._faces) if len(self._faces) else None
        self._distance_request = fcl.DistanceRequest()

    # -- bounds -------------------------------------------------------------------
    def kd_distance(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Distance to the nearest dense surface point (an upper bound) and its mesh."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        if self._tree is None:
            return np.full(len(points), np.inf), np.full(len(points), -1)
        d, i = self._tree.query(points, workers=-1)
        return d, self._tree_owner[i]

    def lower_bound(self, points) -> np.ndarray:
        """A lower bound of the distance from each point to the nearest surface."""
        return np.maximum(self.kd_distance(points)[0] - self.cover_radius, 0.0)

    # -- yes/no ---------------------------------------------------------------------
    def points_clear(self, points, radius: float, check_inside: bool = True) -> np.ndarray:
        """True where a point is outside every mesh and at least ``radius`` from all of them."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        upper, _ = self.kd_distance(points)
        ok = upper - self.cover_radius >= radius
        unsure = np.flatnonzero(~ok & (upper >= radius))
        if len(unsure) and self._all is not None:
            ball = fcl.CollisionObject(fcl.Sphere(float(radius)), fcl.Transform())
            request = fcl.CollisionRequest()
            for k in unsure:
                ball.setTranslation(points[k])
                ok[k] = not fcl.collide(ball, self._all, request, fcl.CollisionResult())
        if check_inside and self.rays is not None and ok.any():
            idx = np.flatnonzero(ok)
            ok[idx] = self.rays.inside(points[idx]) < 0
        return ok

    def segments_clear(self, starts, ends, radius: float, lower_start=None, lower_end=None) -> np.ndarray:
        """True where every point of segment start->end keeps ``radius`` from all meshes.

        Assumes the endpoints are outside the meshes (a segment that enters one crosses its
        surface and so fails). A segment whose endpoints' clearance bounds ``c1``, ``c2``
        satisfy ``(c1 + c2 - length) / 2 >= radius`` is clear without a query; the rest go
        to FCL capsule collision.
        """
        starts = np.asarray(starts, dtype=float).reshape(-1, 3)
        ends = np.asarray(ends, dtype=float).reshape(-1, 3)
        c1 = self.lower_bound(starts) if lower_start is None else lower_start
        c2 = self.lower_bound(ends) if lower_end is None else lower_end
        length = np.linalg.norm(ends - starts, axis=1)
        ok = (c1 + c2 - length) / 2.0 >= radius
        unsure = np.flatnonzero(~ok)
        if len(unsure) and self._all is not None:
            request = fcl.CollisionRequest()
            for k, obj in zip(unsure, self._capsules(starts[unsure], ends[unsure], radius)):
                ok[k] = not fcl.collide(obj, self._all, request, fcl.CollisionResult())
        return ok

    # -- numbers --------------------------------------------------------------------
    def point_distance(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Exact distance from each point to the nearest mesh, and that mesh's index."""
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        dist = np.full(len(points), np.inf)
        which = np.full(len(points), -1)
        for k, p in enumerate(points):
            obj = fcl.CollisionObject(fcl.Sphere(1e-9), fcl.Transform(p))
            dist[k], which[k] = self._nearest(obj)
        return np.maximum(dist, 0.0), which

    def segment_distance(self, starts, ends) -> tuple[np.ndarray, np.ndarray]:
        """Exact minimum distance from each segment to the meshes, and the nearest mesh."""
        starts = np.asarray(starts, dtype=float).reshape(-1, 3)
        ends = np.asarray(ends, dtype=float).reshape(-1, 3)
        dist = np.full(len(starts), np.inf)
        which = np.full(len(starts), -1)
        for k, obj in enumerate(self._capsules(starts, ends, 0.0)):
            dist[k], which[k] = self._nearest(obj)
        return np.maximum(dist, 0.0), which

    def closest_point_on_segment(self, start, end, samples: int = 257) -> tuple[np.ndarray, float]:
        """The point of a segment nearest to the meshes (dense sampling) and its distance."""
        t = np.linspace(0.0, 1.0, samples)[:, None]
        points = np.asarray(start, float) * (1 - t) + np.asarray(end, float) * t
        d, _ = self.point_distance(points)
        k = int(np.argmin(d))
        return points[k], float(d[k])

    # -- helpers --------------------------------------------------------------------
    def _capsules(self, starts, ends, radius):
        """FCL capsules around segments, made lazily; one object per distinct length is reused."""
        v = ends - starts
        length = np.linalg.norm(v, axis=1)
        rot = rotations_z_to(v / np.maximum(length, 1e-300)[:, None])
        mid = (starts + ends) / 2.0
        cache: dict[float, fcl.CollisionObject] = {}
        for k in range(len(starts)):
            if length[k] < 1e-9:
                yield fcl.CollisionObject(fcl.Sphere(max(radius, 1e-9)), fcl.Transform(starts[k]))
                continue
            key = round(float(length[k]), 9)
            obj = cache.get(key)
            if obj is None:
                obj = fcl.CollisionObject(fcl.Capsule(max(radius, 0.0), float(length[k])), fcl.Transform())
                if len(cache) < 64:
                    cache[key] = obj
            obj.setTransform(fcl.Transform(rot[k], mid[k]))
            yield obj

    def _nearest(self, obj) -> tuple[float, int]:
        """Distance from an FCL object to the meshes and the index of the nearest mesh."""
        if self._all is None:
            return np.inf, -1
        result = fcl.DistanceResult()
        d = fcl.distance(obj, self._all, self._distance_request, result)
        # python-fcl reports the BVH triangle in b1 or b2 depending on the pair's order
        triangle = result.b1 if result.b1 >= 0 else result.b2
        owner = int(self._face_owner[triangle]) if 0 <= triangle < len(self._face_owner) else -1
        return max(float(d), 0.0), owner  # overlap comes back as -1
