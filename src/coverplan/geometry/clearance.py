"""Clearance to the scene: exact FCL queries behind a vectorised KD-tree bound.

The KD-tree holds the vertices of every mesh subdivided so no edge is longer than
``cover_edge``; any surface point lies within ``cover_edge / sqrt(3)`` of one of them, so
``kd_distance - cover_radius <= true distance <= kd_distance``. Points whose answer the
bound cannot settle go to FCL (sphere collide for yes/no, distance for numbers).
FCL BVHs are hollow, so "is this point clear" also asks the ray caster whether the point
lies inside a mesh.
"""

from __future__ import annotations

import fcl
import numpy as np
from scipy.spatial import cKDTree

from coverplan.geometry.surface_cover import _bvh, rotations_z_to, surface_cover
from coverplan.geometry.triangle_distance import NearTriangles, segments_near_triangles

# From this many triangles, segment checks halve segments on KD bounds before asking FCL.
HALVING_FROM_TRIANGLES = 100_000
# Up to this many triangles the unsure cases are settled by vectorised exact distances
# (triangle_distance) instead of one FCL query each: 1.5x faster at 92 triangles, even at
# about 128, and 7x slower at 2,048, where testing every triangle's box costs most.
VECTORISED_UP_TO_TRIANGLES = 100
# Above that, and below LOCAL_BELOW_TRIANGLES, an unsure point is tested against only the
# triangles near it (NearTriangles), still vectorised: on a 50,000-triangle building the
# planner's point queries took 0.18 s instead of 0.58 s with one FCL query each, with the same
# answers. Segments keep FCL: a lattice edge's reach holds hundreds of triangles (2.4x slower).
LOCAL_BELOW_TRIANGLES = HALVING_FROM_TRIANGLES


class ClearanceModel:
    """Distances from points and segments to a list of meshes.

    Parameters
    ----------
    meshes : sequence of trimesh.Trimesh
        The meshes measured against.
    rays : RayCaster, optional
        A ray caster over the same meshes, for inside tests.
    cover_edge : float, optional
        The lattice edge of the dense surface points; from the meshes' size when None.
    """

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
        dense_v, dense_owner, radius = [], [], 0.0
        for i, mesh in enumerate(self.meshes):
            v, r = surface_cover(mesh, self.cover_edge)
            dense_v.append(v)
            dense_owner.append(np.full(len(v), i))
            radius = max(radius, r)
        # float64 rounding of lattice points: a hair of extra radius keeps the bound a bound
        self.cover_radius = radius * 1.001 + 1e-9
        self._tree = cKDTree(np.vstack(dense_v)) if dense_v else None
        self._tree_owner = np.concatenate(dense_owner) if dense_owner else np.zeros(0, np.int64)
        self._bvh_all = None
        self._distance_request = fcl.DistanceRequest()
        self._vectorised = 0 < len(self._faces) <= VECTORISED_UP_TO_TRIANGLES
        self._triangles = self._vertices[self._faces] if self._vectorised else None
        self._local = VECTORISED_UP_TO_TRIANGLES < len(self._faces) < LOCAL_BELOW_TRIANGLES
        self._near_index = None

    @property
    def _all(self):
        """One FCL BVH of every triangle, built on first use."""
        if self._bvh_all is None and len(self._faces):
            self._bvh_all = _bvh(self._vertices, self._faces)
        return self._bvh_all

    def _near(self, starts, ends, radius: float) -> np.ndarray:
        """Per segment: does a triangle come closer than ``radius`` (``NearTriangles``, built on
        first use)."""
        if self._near_index is None:
            self._near_index = NearTriangles(self._vertices[self._faces])
        return self._near_index(starts, ends, radius)

    # -- bounds -------------------------------------------------------------------
    def kd_distance(self, points, limit: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
        """Distance to the nearest dense surface point (an upper bound) and its mesh.

        Beyond ``limit`` the answer is inf (mesh -1): bounded searches end early, which matters
        for points far from a scan's millions of vertices.

        Parameters
        ----------
        points : (n, 3) float
            Query points.
        limit : float
            The search radius, metres.

        Returns
        -------
        distance : (n,) float
            Metres, inf beyond ``limit``.
        mesh : (n,) int
            The nearest mesh, -1 beyond ``limit``.
        """
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        if self._tree is None:
            return np.full(len(points), np.inf), np.full(len(points), -1)
        # Threads pay off on big queries only: starting them cost more than most plans' queries.
        d, i = self._tree.query(points, workers=-1 if len(points) > 20_000 else 1, distance_upper_bound=limit)
        found = np.isfinite(d)
        owner = np.full(len(points), -1, dtype=np.int64)
        owner[found] = self._tree_owner[i[found]]
        return d, owner

    def lower_bound(self, points, limit: float = np.inf) -> np.ndarray:
        """A lower bound of the distance from each point to the nearest surface (at most
        ``limit`` - cover radius when nothing is within ``limit``).

        Parameters
        ----------
        points : (n, 3) float
            Query points.
        limit : float
            The search radius, metres.

        Returns
        -------
        (n,) float
            Metres.
        """
        d, _ = self.kd_distance(points, limit)
        return np.maximum(np.minimum(d, limit) - self.cover_radius, 0.0)

    # -- yes/no ---------------------------------------------------------------------
    def points_clear(self, points, radius: float, check_inside: bool = True) -> np.ndarray:
        """Which points keep ``radius`` from every mesh.

        Parameters
        ----------
        points : (n, 3) float
        radius : float
        check_inside : bool
            Also refuse points inside a closed mesh (by ray parity; needs ``rays``).

        Returns
        -------
        clear : (n,) bool
        """
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        upper, _ = self.kd_distance(points, radius + self.cover_radius * 1.01 + 1e-9)
        ok = upper - self.cover_radius >= radius
        unsure = np.flatnonzero(~ok & (upper >= radius))
        if len(unsure) and self._vectorised:
            ok[unsure] = ~segments_near_triangles(points[unsure], points[unsure], self._triangles, radius)
        elif len(unsure) and self._local:
            ok[unsure] = ~self._near(points[unsure], points[unsure], radius)
        elif len(unsure) and self._all is not None:
            ball = fcl.CollisionObject(fcl.Sphere(float(radius)), fcl.Transform())
            request = fcl.CollisionRequest()
            for k in unsure:
                ball.setTranslation(points[k])
                ok[k] = not fcl.collide(ball, self._all, request, fcl.CollisionResult())
        if check_inside and self.rays is not None and ok.any():
            idx = np.flatnonzero(ok)
            ok[idx] = self.rays.inside(points[idx]) < 0
        return ok

    def segments_clear(self, starts, ends, radius: float, lower_start=None, lower_end=None,
                       exact: bool = True) -> np.ndarray:
        """Which segments keep ``radius`` from every mesh at every point.

        Parameters
        ----------
        starts, ends : (n, 3) float
        radius : float
        lower_start, lower_end : (n,) float, optional
            Known lower bounds of the endpoints' clearance (saves their KD-tree queries).
        exact : bool

        Returns
        -------
        clear : (n,) bool

        Assumes the endpoints are outside the meshes (a segment that enters one crosses its
        surface and so fails). A segment whose endpoints' clearance bounds ``c1``, ``c2``
        satisfy ``(c1 + c2 - length) / 2 >= radius`` is clear at once. The others go to FCL
        capsule collision on small meshes; on big ones (where each FCL query near a fine scan
        costs milliseconds) they are halved until each piece is settled by the KD-tree bounds at
        its midpoint, and only pieces too short for the bounds go to FCL, or with
        ``exact=False`` count as not clear (cheaper, and right for graph edges).
        """
        starts = np.asarray(starts, dtype=float).reshape(-1, 3)
        ends = np.asarray(ends, dtype=float).reshape(-1, 3)
        length = np.linalg.norm(ends - starts, axis=1)
        limit = radius + (length.max() if len(length) else 0.0) / 2.0 + self.cover_radius * 1.01 + 1e-9
        c1 = self.lower_bound(starts, limit) if lower_start is None else lower_start
        c2 = self.lower_bound(ends, limit) if lower_end is None else lower_end
        ok = (c1 + c2 - length) / 2.0 >= radius
        todo = np.flatnonzero(~ok)
        if len(todo) and self._vectorised:
            ok[todo] = ~segments_near_triangles(starts[todo], ends[todo], self._triangles, radius)
        elif len(todo) and len(self._faces) < HALVING_FROM_TRIANGLES:
            request = fcl.CollisionRequest()
            for k, obj in zip(todo, self._capsules(starts[todo], ends[todo], radius)):
                ok[k] = not fcl.collide(obj, self._all, request, fcl.CollisionResult())
        elif len(todo):
            ok[todo] = self._halving_check(starts[todo], ends[todo], radius, exact)
        return ok

    def _halving_check(self, a, b, radius: float, exact: bool) -> np.ndarray:
        clear = np.ones(len(a), dtype=bool)
        owner = np.arange(len(a))
        r = self.cover_radius
        request = fcl.CollisionRequest()
        while len(owner):
            centre = (a + b) / 2.0
            half = np.linalg.norm(b - a, axis=1) / 2.0
            limit = radius + half.max() + r * 1.01 + 1e-9
            upper, _ = self.kd_distance(centre, limit)
            lower = np.minimum(upper, limit) - r
            too_close = upper < radius  # the midpoint itself breaks the distance
            clear[owner[too_close]] = False
            settled = too_close | (lower - half >= radius) | ~clear[owner]
            tiny = ~settled & (half <= r)
            for k in np.flatnonzero(tiny):
                if not clear[owner[k]]:
                    continue
                if not exact:
                    clear[owner[k]] = False
                    continue
                obj = next(self._capsules(a[k:k + 1], b[k:k + 1], radius))
                if fcl.collide(obj, self._all, request, fcl.CollisionResult()):
                    clear[owner[k]] = False
            split = ~settled & ~tiny
            mid = centre[split]
            a = np.vstack([a[split], mid])
            b = np.vstack([mid, b[split]])
            owner = np.concatenate([owner[split], owner[split]])
        return clear

    # -- numbers --------------------------------------------------------------------
    def point_distance(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Exact distance from each point to the nearest mesh, and that mesh's index.

        Parameters
        ----------
        points : (n, 3) float
            Query points.

        Returns
        -------
        distance : (n,) float
            Metres.
        mesh : (n,) int
            The nearest mesh.
        """
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        dist = np.full(len(points), np.inf)
        which = np.full(len(points), -1)
        for k, p in enumerate(points):
            obj = fcl.CollisionObject(fcl.Sphere(1e-9), fcl.Transform(p))
            dist[k], which[k] = self._nearest(obj)
        return np.maximum(dist, 0.0), which

    def segment_distance(self, starts, ends) -> tuple[np.ndarray, np.ndarray]:
        """Exact minimum distance from each segment to the meshes, and the nearest mesh.

        Parameters
        ----------
        starts, ends : (n, 3) float
            The segments' ends.

        Returns
        -------
        distance : (n,) float
            Metres.
        mesh : (n,) int
            The nearest mesh.
        """
        starts = np.asarray(starts, dtype=float).reshape(-1, 3)
        ends = np.asarray(ends, dtype=float).reshape(-1, 3)
        dist = np.full(len(starts), np.inf)
        which = np.full(len(starts), -1)
        for k, obj in enumerate(self._capsules(starts, ends, 0.0)):
            dist[k], which[k] = self._nearest(obj)
        return np.maximum(dist, 0.0), which

    def polyline_clearance(self, points, security: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per segment of a polyline: clearance, nearest mesh, and whether the number is exact.

        Exact (FCL) for every segment that might come closer than ``security`` or might hold
        the polyline's minimum; the others, provably farther, get their lower bound.

        Parameters
        ----------
        points : (n, 3) float
            The polyline.
        security : float
            The security distance, metres.

        Returns
        -------
        clearance : (n - 1,) float
            Metres.
        mesh : (n - 1,) int
            The nearest mesh.
        exact : (n - 1,) bool
            Whether the clearance is exact or a lower bound.
        """
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        a, b = points[:-1], points[1:]
        length = np.linalg.norm(b - a, axis=1)
        limit = 3.0 * security + length.max() + self.cover_radius * 1.01
        upper, owner = self.kd_distance(points, limit)
        lower = np.maximum(np.minimum(upper, limit) - self.cover_radius, 0.0)
        seg_lower = np.maximum((lower[:-1] + lower[1:] - length) / 2.0, 0.0)
        seg_upper = np.minimum(upper[:-1], upper[1:])
        exact = (seg_lower < security) | (seg_lower <= seg_upper.min())
        dist = seg_lower.copy()
        which = np.where(upper[:-1] <= upper[1:], owner[:-1], owner[1:])
        if exact.any():
            dist[exact], which[exact] = self.segment_distance(a[exact], b[exact])
        return dist, which, exact

    def closest_point_on_segment(self, start, end, samples: int = 257) -> tuple[np.ndarray, float]:
        """The point of a segment nearest to the meshes (dense sampling) and its distance.

        Parameters
        ----------
        start, end : (3,) float
            The segment.
        samples : int
            Points tested along it.

        Returns
        -------
        point : (3,) float
            The nearest sampled point.
        distance : float
            Its distance, metres.
        """
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
