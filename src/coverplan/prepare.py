"""Mesh preparation every load goes through; each step says what it changed."""

from __future__ import annotations

import numpy as np
import trimesh

from .errors import InputFileError


def prepare_mesh(mesh: trimesh.Trimesh, label: str) -> tuple[trimesh.Trimesh, list[str]]:
    """Clean one mesh for planning. Returns the mesh and notes on what was done.

    Refuses NaN/inf vertices. Merges duplicate vertices, drops degenerate and duplicate
    faces, and orients normals outward where the mesh is a closed solid.
    """
    notes: list[str] = []
    vertices = np.asarray(mesh.vertices, dtype=float)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if len(faces) == 0:
        raise InputFileError(label, "mesh has no faces")
    bad = ~np.isfinite(vertices).all(axis=1)
    if bad.any():
        raise InputFileError(label, f"{int(bad.sum())} vertices have NaN or infinite coordinates")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise InputFileError(label, "faces refer to vertices that do not exist")
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    n_vertices, n_faces = len(mesh.vertices), len(mesh.faces)
    scale = float(np.ptp(vertices, axis=0).max()) or 1.0
    mesh.merge_vertices(digits_vertex=max(0, int(-np.floor(np.log10(scale * 1e-8)))))
    if len(mesh.vertices) < n_vertices:
        notes.append(f"{label}: merged {n_vertices - len(mesh.vertices)} duplicate vertices")
    keep = mesh.nondegenerate_faces(height=scale * 1e-9) & (mesh.area_faces > (scale * 1e-7) ** 2)
    if not keep.all():
        notes.append(f"{label}: dropped {int((~keep).sum())} degenerate faces")
        mesh.update_faces(keep)
    unique = mesh.unique_faces()
    if len(unique) < len(mesh.faces):
        mask = np.zeros(len(mesh.faces), dtype=bool)
        mask[unique] = True
        notes.append(f"{label}: dropped {len(mesh.faces) - len(unique)} duplicate faces")
        mesh.update_faces(mask)
    mesh.remove_unreferenced_vertices()
    if len(mesh.faces) == 0:
        raise InputFileError(label, f"mesh has no usable faces (all {n_faces} are degenerate)")
    if mesh.is_watertight:
        before = mesh.faces.copy()
        trimesh.repair.fix_normals(mesh, multibody=True)
        flipped = int((mesh.faces != before).any(axis=1).sum())
        if flipped:
            notes.append(f"{label}: re-oriented {flipped} faces so normals point outward")
    else:
        notes.append(f"{label}: not a closed solid; inside/outside comes from ray parity")
    return mesh, notes
