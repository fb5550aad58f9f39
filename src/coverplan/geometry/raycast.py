"""Batched ray casting over all scene meshes with Embree (through embreex).

One Embree geometry per mesh, so every hit says which mesh it struck. Embree works in
float32: callers pass local coordinates (the scene shifts georeferenced input first).
"""

from __future__ import annotations

import numpy as np

try:
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh
except ImportError as exc:  # pragma: no cover - embreex is a hard dependency
    raise ImportError(
        "coverplan needs embreex for ray casting (pip install embreex); without it "
        "visibility would be thousands of times slower") from exc

# Directions for inside tests: irrational-looking so rays rarely graze edges exactly.
_PARITY_DIRECTIONS = np.array([
    [0.2672612, 0.5345225, 0.8017837],
    [-0.6246950, 0.3123475, -0.7161149],
    [0.4472136, -0.8728716, 0.1951800],
])
_F32 = np.float32


class RayCaster:
    """First hits, segment occlusion and inside tests against a list of meshes.

    Parameters
    ----------
    meshes : sequence of trimesh.Trimesh
        Closed meshes.
    epsilon : float
        Metres cut from each segment's end, so a segment ending on a surface is not blocked by it.
    sheets : sequence of trimesh.Trimesh
        Open surfaces that block rays (the terrain).
    """

    def __init__(self, meshes, epsilon: float = 1e-4, sheets=()):
        """``sheets`` (the terrain) block rays and report hits with indices after the meshes',
        but are open surfaces: inside tests ignore them."""
        self._scene = rtcore_scene.EmbreeScene()
        self._keep = []
        self.n_meshes = len(meshes)
        self.epsilon = float(epsilon)
        for mesh in list(meshes) + list(sheets):
            tm = TriangleMesh(scene=self._scene,
                              vertices=np.ascontiguousarray(mesh.vertices, dtype=_F32),
                              indices=np.ascontiguousarray(mesh.faces, dtype=np.int32))
            self._keep.append(tm)

    def first_hit(self, origins, directions, max_distance=None):
        """Distance, mesh index and face index of the first hit per ray (-1 / inf if none).

        Parameters
        ----------
        origins, directions : (n, 3) float
            Rays; directions need not be unit.
        max_distance : float or (n,) float, optional
            Farthest hit counted.

        Returns
        -------
        distance : (n,) float
            Metres along the ray.
        mesh, face : (n,) int
            Indices of what was hit.
        """
        origins = np.ascontiguousarray(origins, dtype=_F32).reshape(-1, 3)
        directions = np.asarray(directions, dtype=float).reshape(-1, 3)
        directions = np.ascontiguousarray(
            directions / np.linalg.norm(directions, axis=1, keepdims=True), dtype=_F32)
        if len(origins) == 0:
            return np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int64)
        if max_distance is None:
            out = self._scene.run(origins, directions, output=1)
        else:
            dists = np.ascontiguousarray(np.broadcast_to(max_distance, len(origins)), dtype=_F32)
            out = self._scene.run(origins, directions, dists=dists, output=1)
        geom = out["geomID"].astype(np.int64)
        dist = np.where(geom >= 0, out["tfar"].astype(float), np.inf)
        return dist, geom, out["primID"].astype(np.int64)

    def segments_blocked(self, starts, ends, chunk: int = 2_000_000) -> np.ndarray:
        """True where the open segment start->end hits any mesh (its end excluded by epsilon).

        Parameters
        ----------
        starts, ends : (n, 3) float
            The segments.
        chunk : int
            Segments per Embree call.

        Returns
        -------
        (n,) bool
            Blocked segments.
        """
        starts = np.asarray(starts, dtype=float).reshape(-1, 3)
        ends = np.asarray(ends, dtype=float).reshape(-1, 3)
        result = np.empty(len(starts), dtype=bool)
        for lo in range(0, len(starts), chunk):
            s, e = starts[lo:lo + chunk], ends[lo:lo + chunk]
            v = e - s
            length = np.linalg.norm(v, axis=1)
            d = v / np.maximum(length, 1e-300)[:, None]
            dists = np.maximum(length - self.epsilon, 0.0)
            hit = self._scene.run(np.ascontiguousarray(s, dtype=_F32), np.ascontiguousarray(d, dtype=_F32),
                                  dists=np.ascontiguousarray(dists, dtype=_F32), query="OCCLUDED")
            result[lo:lo + chunk] = (np.asarray(hit) != -1) & (length > self.epsilon)
        return result

    def crossings(self, points, direction, max_hits: int = 256) -> np.ndarray:
        """Per point and mesh, how many surfaces a ray from the point crosses: (n, n_meshes).

        Parameters
        ----------
        points : (n, 3) float
            Ray origins.
        direction : (3,) float
            The rays' direction.
        max_hits : int
            The most surfaces followed per ray.

        Returns
        -------
        (n, n_meshes) int
            Crossing counts.
        """
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        counts = np.zeros((len(points), max(self.n_meshes, 1)), dtype=np.int32)
        origins = points.copy()
        d = np.broadcast_to(np.asarray(direction, dtype=float), origins.shape)
        live = np.arange(len(points))
        for _ in range(max_hits):
            if len(live) == 0:
                break
            dist, geom, _face = self.first_hit(origins[live], d[live])
            hit = geom >= 0
            live, dist, geom = live[hit], dist[hit], geom[hit]
            solid = geom < self.n_meshes
            np.add.at(counts, (live[solid], geom[solid]), 1)
            origins[live] = origins[live] + d[live] * (dist + self.epsilon)[:, None]
        return counts

    def inside_each(self, points) -> np.ndarray:
        """(n, n_meshes) bool: inside each mesh by the majority of three parity rays.

        Parameters
        ----------
        points : (n, 3) float
            Query points.

        Returns
        -------
        (n, n_meshes) bool
            Inside each mesh.
        """
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        votes = np.zeros((len(points), max(self.n_meshes, 1)), dtype=np.int32)
        if self.n_meshes == 0 or len(points) == 0:
            return votes[:, :self.n_meshes] > 0
        votes += self.crossings(points, _PARITY_DIRECTIONS[0]) % 2
        votes += self.crossings(points, _PARITY_DIRECTIONS[1]) % 2
        # Where the first two rays agree the third cannot change the majority.
        split = np.flatnonzero((votes == 1).any(axis=1))
        if len(split):
            votes[split] += self.crossings(points[split], _PARITY_DIRECTIONS[2]) % 2
        return votes >= 2

    def inside(self, points) -> np.ndarray:
        """Index of a mesh each point lies inside, else -1.

        Parameters
        ----------
        points : (n, 3) float
            Query points.

        Returns
        -------
        (n,) int
            A mesh index or -1.
        """
        inside = self.inside_each(points)
        if inside.shape[1] == 0:
            return np.full(len(inside), -1, dtype=np.int64)
        return np.where(inside.any(axis=1), np.argmax(inside, axis=1), -1)
