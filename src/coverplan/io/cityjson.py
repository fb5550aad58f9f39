"""CityJSON 1.0-2.0 files and CityJSONSeq (.jsonl): city objects as meshes, LoD by LoD.

Vertices are integers times ``transform.scale`` plus ``transform.translate``. A top-level
object takes the geometry of its children (3D BAG keeps it on the BuildingParts).
"""

from __future__ import annotations

import json
import zlib

import numpy as np

from coverplan.errors import InputFileError
from coverplan.files import open_maybe_gzip
from coverplan.io.city import CityModel, CityObject, parse_crs, triangulate_rings
from coverplan.io.registry import MeshSource, register_city_reader, register_reader


def _load(path):
    try:
        with open_maybe_gzip(path, "rt") as handle:
            text = handle.read()
    except (OSError, EOFError, zlib.error) as exc:
        raise InputFileError(path, f"cannot be read ({exc})") from None
    try:
        if path.name.lower().removesuffix(".gz").endswith(".jsonl"):
            lines = [json.loads(line) for line in text.splitlines() if line.strip()]
            if not lines or lines[0].get("type") != "CityJSON":
                raise InputFileError(path, "is not CityJSONSeq: the first line must be a CityJSON object")
            header = lines[0]
            features = lines[1:]
        else:
            header = json.loads(text)
            features = []
    except json.JSONDecodeError as exc:
        raise InputFileError(path, f"is not valid JSON ({exc.msg} at line {exc.lineno})") from None
    if not isinstance(header, dict) or header.get("type") != "CityJSON":
        raise InputFileError(path, "is not CityJSON (its 'type' is not \"CityJSON\")")
    return header, features


EXTENSIONS = ("city.json", "json", "city.jsonl", "jsonl", "json.gz", "jsonl.gz")


@register_reader(*EXTENSIONS)
def read_cityjson(path, building: str | None = None, lod: int | None = None,
                  context_radius: float | None = None, **_ignored) -> MeshSource:
    """Read one building of a CityJSON file and its neighbours.

    Parameters
    ----------
    path : str or Path
        The file.
    building : str, optional
        An id or a name.
    lod : int, optional
        The level of detail.
    context_radius : float, optional
        Metres around the building whose objects are obstacles.
    **_ignored
        Options of other readers.

    Returns
    -------
    MeshSource
        The target first, then the obstacles.
    """
    return read_cityjson_model(path).source(building, context_radius, lod)


@register_city_reader(*EXTENSIONS)
def read_cityjson_model(path) -> CityModel:
    """Every city object of a CityJSON / CityJSONSeq file.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    CityModel
        Its objects.
    """
    try:
        header, features = _load(path)
    except UnicodeDecodeError:
        raise InputFileError(path, "is not UTF-8 text") from None
    transform = header.get("transform") or {}
    if not isinstance(transform, dict):
        raise InputFileError(path, "'transform' must be an object with 'scale' and 'translate'")
    try:
        scale = np.asarray(transform.get("scale", [1, 1, 1]), dtype=float).reshape(3)
        translate = np.asarray(transform.get("translate", [0, 0, 0]), dtype=float).reshape(3)
    except (TypeError, ValueError):
        raise InputFileError(path, "'transform' scale and translate must be three numbers each") from None
    metadata = header.get("metadata") or {}
    reference = metadata.get("referenceSystem") or metadata.get("crs") if isinstance(metadata, dict) else None
    crs = parse_crs(reference if isinstance(reference, str) else json.dumps(reference))
    chunks = [(header.get("CityObjects"), header.get("vertices"))]
    chunks += [(f.get("CityObjects"), f.get("vertices")) for f in features if isinstance(f, dict)]
    objects, skipped = [], 0
    for city_objects, vertices in chunks:
        city_objects = city_objects or {}
        try:
            verts = np.asarray(vertices or [], dtype=float).reshape(-1, 3) * scale + translate
        except (ValueError, TypeError):
            raise InputFileError(path, "has vertices that are not triples of numbers") from None
        if not isinstance(city_objects, dict):
            raise InputFileError(path, "'CityObjects' must be an object")
        for oid, obj in city_objects.items():
            if not isinstance(obj, dict) or obj.get("parents"):
                continue
            attributes = obj.get("attributes") if isinstance(obj.get("attributes"), dict) else {}
            city = CityObject(str(oid), str(obj.get("type", "CityObject")), attributes.get("name"),
                              attributes=attributes)
            children = obj.get("children") if isinstance(obj.get("children"), list) else []
            parts = [obj] + [city_objects.get(c) for c in children if isinstance(c, str)]
            for part in parts:
                geometries = part.get("geometry") if isinstance(part, dict) else None
                for geom in geometries if isinstance(geometries, list) else []:
                    skipped += _add_geometry(city, geom, verts) if isinstance(geom, dict) else 1
            objects.append(city)
    if not objects:
        raise InputFileError(path, "holds no city objects")
    return CityModel(path, objects, crs, skipped)


def _surfaces(kind: str, boundaries) -> list:
    """Each surface (a list of rings of vertex indices) in a geometry's boundaries."""
    depth = {"MultiSurface": 0, "CompositeSurface": 0, "Solid": 1, "MultiSolid": 2, "CompositeSolid": 2}.get(kind)
    level = [boundaries] if isinstance(boundaries, list) else []
    if depth is None:
        return []
    for _ in range(depth + 1):
        level = [item for group in level if isinstance(group, list) for item in group]
    return [s for s in level if isinstance(s, list)]


def _add_geometry(city: CityObject, geom: dict, verts: np.ndarray) -> int:
    """Triangulate one geometry into ``city``; returns how many surfaces had to be skipped."""
    kind = geom.get("type")
    try:
        level = int(float(geom.get("lod", 0)))
    except (TypeError, ValueError):
        return 1
    skipped = 0
    for surface in _surfaces(kind, geom.get("boundaries")):
        try:
            rings = [verts[np.asarray(ring, dtype=np.int64).reshape(-1)] for ring in surface]
        except (IndexError, ValueError, TypeError, OverflowError):
            skipped += 1
            continue
        tri = triangulate_rings(rings)
        if tri is None:
            skipped += 1
        else:
            city.add(level, tri)
    return skipped
