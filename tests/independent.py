"""Checks written apart from coverplan's own geometry code, to judge it.

Occlusion by brute-force Moller-Trumbore in numpy (no Embree), distances by trimesh's
proximity queries on densely sampled polylines (no FCL), frustum by plain trigonometry.
Fine for the small scenes tests use.
"""

from __future__ import annotations

import numpy as np
import trimesh


def segment_hits_triangles(starts, ends, triangles, eps=1e-7) -> np.ndarray:
    """True where the open segment start->end crosses any triangle (n_seg x n_tri brute force)."""
    starts = np.asarray(starts, float)
    ends = np.asarray(ends, float)
    tri = np.asarray(triangles, float)
    d = ends - starts
    v0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    hit = np.zeros(len(starts), dtype=bool)
    for lo in range(0, len(starts), 2000):
        s, dd = starts[lo:lo + 2000, None, :], d[lo:lo + 2000, None, :]
        p = np.cross(dd, e2[None])
        det = np.einsum("ijk,ijk->ij", p, np.broadcast_to(e1[None], p.shape))
        ok = np.abs(det) > 1e-12
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        t = s - v0[None]
        u = np.einsum("ijk,ijk->ij", t, p) * inv
        q = np.cross(t, np.broadcast_to(e1[None], t.shape))
        v = np.einsum("ijk,ijk->ij", np.broadcast_to(dd, q.shape), q) * inv
        w = np.einsum("ijk,ijk->ij", np.broadcast_to(e2[None], q.shape), q) * inv
        inside = ok & (u >= -eps) & (v >= -eps) & (u + v <= 1 + eps) & (w > eps) & (w < 1 - eps)
        hit[lo:lo + 2000] = inside.any(axis=1)
    return hit


def camera_frame(heading_deg, pitch_deg):
    h, p = np.radians(heading_deg), np.radians(pitch_deg)
    forward = np.array([np.cos(p) * np.sin(h), np.cos(p) * np.cos(h), np.sin(p)])
    right = np.array([np.cos(h), -np.sin(h), 0.0])
    return right, np.cross(right, forward), forward


def images(position, heading, pitch, camera, points, normals, triangles, d_opt, max_incidence_deg,
           offset=1e-3) -> np.ndarray:
    """Boolean per point: does this one shot image it (docs/design.md's four conditions)?"""
    right, up, forward = camera_frame(heading, pitch)
    v = points - position
    dist = np.linalg.norm(v, axis=1)
    z, x, y = v @ forward, v @ right, v @ up
    in_frustum = (z > 0) & (np.abs(x) <= z * camera.tan_half_hfov) & (np.abs(y) <= z * camera.tan_half_vfov)
    cos_inc = -(v * normals).sum(axis=1) / dist
    facing = cos_inc >= np.cos(np.radians(max_incidence_deg))
    ok = in_frustum & facing & (dist <= d_opt)
    idx = np.flatnonzero(ok)
    if len(idx):
        blocked = segment_hits_triangles(points[idx] + normals[idx] * offset,
                                         np.repeat(position[None], len(idx), axis=0), triangles)
        ok[idx[blocked]] = False
    return ok


def polyline_min_distance(positions, meshes, step: float) -> float:
    """Smallest distance from points every ``step`` along the polyline to any mesh."""
    pts = [positions[:1]]
    for a, b in zip(positions[:-1], positions[1:]):
        n = max(int(np.ceil(np.linalg.norm(b - a) / step)), 1)
        t = np.linspace(0.0, 1.0, n + 1)[1:, None]
        pts.append(a * (1 - t) + b * t)
    pts = np.vstack(pts)
    best = np.inf
    for mesh in meshes:
        _closest, dist, _tri = trimesh.proximity.closest_point(mesh, pts)
        inside = mesh.contains(pts) if mesh.is_watertight else np.zeros(len(pts), bool)
        dist = np.where(inside, 0.0, dist)
        best = min(best, float(dist.min()))
    return best


def frame_share(position, heading, pitch, camera, mesh, normal, facing_deg: float, grid=(48, 32)) -> float:
    """Share of a shot's frame whose first hit on ``mesh`` faces within ``facing_deg`` of
    ``normal`` (trimesh's pure-numpy ray tester, a pixel grid finer than the planner's)."""
    from trimesh.ray.ray_triangle import RayMeshIntersector
    right, up, forward = camera_frame(heading, pitch)
    gx, gy = grid
    u = camera.tan_half_hfov * ((np.arange(gx) + 0.5) / gx * 2 - 1)
    v = camera.tan_half_vfov * ((np.arange(gy) + 0.5) / gy * 2 - 1)
    uu, vv = (a.ravel() for a in np.meshgrid(u, v))
    d = forward[None] + uu[:, None] * right[None] - vv[:, None] * up[None]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.repeat(np.asarray(position, float)[None], len(d), axis=0)
    tri, ray = RayMeshIntersector(mesh).intersects_id(o, d, multiple_hits=False, return_locations=False)
    n = mesh.face_normals[tri]
    n = n * -np.sign((n * d[ray]).sum(axis=1))[:, None]
    facing = n @ np.asarray(normal, float) >= np.cos(np.radians(facing_deg))
    return float(facing.sum()) / len(d)


def per_sample_links(positions, cam, pt, points, normals, max_pair_deg, max_incidence_deg, min_overlap):
    """Which photos link, judged sample by sample: a shared sample counts when both photos see
    it within ``max_incidence_deg`` of its normal and their rays meet at most ``max_pair_deg``
    apart; two photos link when the counted samples are ``min_overlap`` of the smaller footprint.
    Written straight from that definition: every pair of views of every sample, one by one."""
    n = len(positions)
    views = {}
    for c, p in zip(cam.tolist(), pt.tolist()):
        views.setdefault(p, []).append(c)
    size = np.bincount(cam, minlength=n)
    count = np.zeros((n, n), dtype=np.int64)
    cos_pair, cos_inc = np.cos(np.radians(max_pair_deg)), np.cos(np.radians(max_incidence_deg))
    for p, cams in views.items():
        rays = {c: (positions[c] - points[p]) / np.linalg.norm(positions[c] - points[p]) for c in cams}
        square = [c for c in cams if rays[c] @ normals[p] >= cos_inc]
        for i, a in enumerate(square):
            for b in square[i + 1:]:
                if rays[a] @ rays[b] >= cos_pair:
                    count[a, b] += 1
                    count[b, a] += 1
    links = (count > 0) & (count >= min_overlap * np.minimum(size[:, None], size[None, :]))
    np.fill_diagonal(links, False)
    return links
