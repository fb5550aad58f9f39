"""Where a route's scene came from: the files and options ``load_scene`` read, so that
``report``, ``evaluate``, ``simulate`` and ``export`` can load the scene from the route alone
(``io.load.scene_from_record``).

The record lists every file (targets, obstacles, point clouds, the DTM) with its SHA-256 and
every option that shaped the scene (units, building id, georeference, ...). In a route file the
paths are relative to the route's folder where they can be, so that a project folder moves as a
whole; ``scene_from_record`` finds them again and names a file that moved or changed.
"""

from __future__ import annotations

import hashlib
import os
from functools import lru_cache
from pathlib import Path

FILE_LISTS = ("targets", "obstacles", "obstacle_points")
OPTIONS = ("units", "ground", "target_names", "up_axis", "building", "lod", "context_radius", "crs", "geodetic_origin",
           "points_resolution", "point_classes", "height_attribute", "height", "roof_attribute")


def file_hash(path) -> str:
    """SHA-256 of a file's bytes, hex (a file unchanged since it was last hashed is not read again:
    a route's scene is checked against its record, then recorded again as it loads).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    str
        64 hex digits.
    """
    path = Path(path).resolve()
    stat = path.stat()
    return _hash(str(path), stat.st_size, stat.st_mtime_ns)


@lru_cache(maxsize=256)
def _hash(path: str, _size: int, _mtime_ns: int) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def scene_record(files: dict, options: dict) -> dict | None:
    """The record of a scene read from ``files`` (name in ``FILE_LISTS`` -> paths, "terrain" -> a
    path or None) with ``options`` (``load_scene``'s keyword arguments); None when a target was
    not a file (a city file read once by ``batch``).

    Parameters
    ----------
    files : dict
        ``FILE_LISTS`` names to paths, and ``terrain``.
    options : dict
        ``load_scene``'s keyword arguments.

    Returns
    -------
    dict or None
        {"files": {name: [{"path": absolute path, "sha256": hex}, ...]}, "terrain": {...} or
        None, "options": {name: value}}.
    """
    lists = {name: [_entry(p) for p in files.get(name, ())] for name in FILE_LISTS}
    if any(entry is None for entries in lists.values() for entry in entries):
        return None
    terrain = files.get("terrain")
    return {"files": lists, "terrain": None if terrain is None else _entry(terrain),
            "options": {k: _plain(options.get(k)) for k in OPTIONS if options.get(k) is not None}}


def _entry(path) -> dict | None:
    if not isinstance(path, (str, os.PathLike)) or not Path(path).is_file():
        return None
    return {"path": str(Path(path).resolve()), "sha256": file_hash(path)}


def _plain(value):
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "item"):  # numpy scalars
        return value.item()
    return value
