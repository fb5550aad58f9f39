"""What the pictures frame: the target, its flight and what lies within the flight's reach,
not the whole city tile the obstacles came from; meshes thinned for display."""

from __future__ import annotations

import numpy as np

MAX_DISPLAY_FACES = 300_000


def focus_bounds(route, scene) -> tuple[np.ndarray, np.ndarray]:
    """Box around the target and every waypoint, padded by the security distance plus a few
    metres; obstacles beyond it are cut off by the picture's edge.

    Parameters
    ----------
    route : Route
        The route drawn.
    scene : Scene
        Its scene.

    Returns
    -------
    lo, hi : (3,) float
        The box's corners in the local frame.
    """
    lo, hi = scene.bounds("target")
    lo = np.minimum(lo, route.positions.min(axis=0))
    hi = np.maximum(hi, route.positions.max(axis=0))
    pad = route.security + 5.0
    lo, hi = lo - pad, hi + pad
    lo[2] = min(lo[2] + pad, float(scene.ground_z))  # down to the ground, no further
    return lo, hi


def display_mesh(mesh, max_faces: int = MAX_DISPLAY_FACES):
    """Vertices and faces for display; very large meshes are thinned by vertex clustering.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The mesh to draw.
    max_faces : int
        Meshes with more faces are thinned.

    Returns
    -------
    vertices : (n, 3) float
    faces : (m, 3) int
    """
    vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    if len(faces) <= max_faces:
        return vertices, faces
    cell = np.sqrt(mesh.area / max_faces) * 1.2
    key = np.floor(vertices / cell).astype(np.int64)
    _, cluster, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    cluster = cluster.ravel()
    merged = np.zeros((len(counts), 3))
    np.add.at(merged, cluster, vertices)
    merged /= counts[:, None]
    f = cluster[faces]
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    return merged, f[keep]
