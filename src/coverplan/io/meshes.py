"""Mesh files through trimesh: OBJ, PLY, STL, OFF, GLB/glTF (several objects each)."""

from __future__ import annotations

import warnings

import numpy as np
import trimesh

from coverplan.errors import InputFileError
from coverplan.io.registry import MeshSource, register_reader

# glTF is y-up by specification; everything else is taken as z-up unless told.
_DEFAULT_UP = {"glb": "y", "gltf": "y"}
_Y_UP_TO_Z_UP = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])


@register_reader("obj", "ply", "stl", "off", "glb", "gltf")
def read_mesh(path, up_axis: str | None = None, **_ignored) -> MeshSource:
    """Read an OBJ, PLY, STL, OFF, GLB or glTF file: one mesh per body or named object.

    Parameters
    ----------
    path : str or Path
        The file.
    up_axis : {"y", "z"}, optional
        The file's up axis; from the format's convention when None.
    **_ignored
        Options of other readers.

    Returns
    -------
    MeshSource
        Named meshes.
    """
    ext = path.suffix.lower().lstrip(".")
    _check_signature(path, ext)
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")  # numpy casts of garbage values while parsing
            loaded = trimesh.load(str(path), force="scene", process=False)
    except Exception as exc:  # trimesh raises many types on malformed files
        raise InputFileError(path, f"cannot be read as .{ext} ({_short(exc)})") from None
    up = (up_axis or _DEFAULT_UP.get(ext, "z")).lower()
    if up not in ("y", "z"):
        raise InputFileError(path, f"up axis must be 'y' or 'z', got {up_axis!r}")
    meshes = []
    try:
        for node in loaded.graph.nodes_geometry:
            transform, geometry_name = loaded.graph[node]
            geometry = loaded.geometry.get(geometry_name)
            if not isinstance(geometry, trimesh.Trimesh) or len(geometry.faces) == 0:
                continue
            mesh = trimesh.Trimesh(vertices=np.array(geometry.vertices, dtype=float),
                                   faces=np.array(geometry.faces, dtype=np.int64), process=False)
            mesh.apply_transform(transform)
            if up == "y":
                mesh.apply_transform(_Y_UP_TO_Z_UP)
            meshes.append((str(node), mesh))
    except Exception as exc:
        raise InputFileError(path, f"cannot be read as .{ext} ({_short(exc)})") from None
    if not meshes:
        raise InputFileError(path, "holds no triangles (no faces in any object)")
    notes = [f"{path.name}: read as {up}-up"] if up == "y" else []
    return MeshSource(meshes=meshes, notes=notes)


def _check_signature(path, ext: str) -> None:
    """Refuse a file that is not of its extension's format at all (random bytes, another
    format renamed), which trimesh would read as an empty or garbage mesh."""
    with open(path, "rb") as fh:
        head = fh.read(4096)
    if ext == "stl":
        size = path.stat().st_size
        binary = size >= 84 and size == 84 + 50 * int(np.frombuffer(head[80:84], "<u4")[0])
        ascii_ = head.lstrip().lower().startswith(b"solid") and b"\0" not in head
        if not (binary or ascii_):
            raise InputFileError(path, "is not a valid STL: neither binary (84 bytes + 50 per triangle) nor ASCII "
                                       "(starting 'solid')")
    elif ext in ("obj", "off") and b"\0" in head:
        raise InputFileError(path, f"is not a valid {ext.upper()}: it is binary, not text")


def _short(exc: Exception) -> str:
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return text[:120]
