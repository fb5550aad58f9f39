"""What CityGML and CityJSON readers share: CRS strings, polygon triangulation, picking the
target building and the city objects around it that become obstacles."""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import mapbox_earcut
import numpy as np
import trimesh

from ..errors import InputFileError, ParameterError
from . import MeshSource

DEFAULT_CONTEXT_RADIUS = 150.0
_EPSG = re.compile(r"EPSG(?:/|:)+(?:[0-9.]+[:/])?(\d{4,6})", re.IGNORECASE)


def parse_crs(text: str | None) -> tuple[str | None, str | None]:
    """(horizontal, vertical) 'EPSG:n' codes from an srsName / referenceSystem string.

    Handles 'EPSG:25832', 'urn:ogc:def:crs:EPSG::25832', OGC URLs
    '.../def/crs/EPSG/0/7415' and compound URNs 'urn:ogc:def:crs,crs:EPSG:6.12:3068,crs:EPSG:6.12:5783'.
    """
    if not text:
        return None, None
    codes = _EPSG.findall(text)
    if not codes:
        return None, None
    horizontal = f"EPSG:{codes[0]}"
    vertical = f"EPSG:{codes[1]}" if len(codes) > 1 else None
    return horizontal, vertical


def triangulate_rings(rings: list[np.ndarray]) -> np.ndarray | None:
    """Triangles (n, 3, 3) of one planar polygon given as 3D rings (exterior first, then holes).

    Rings may repeat their first point at the end. The polygon is projected on its own
    plane (Newell normal), triangulated with earcut, and the triangles keep the exterior
    ring's orientation. Returns None for a polygon that cannot be triangulated.
    """
    clean = []
    for ring in rings:
        r = np.asarray(ring, dtype=float).reshape(-1, 3)
        if len(r) > 1 and np.allclose(r[0], r[-1], rtol=0.0, atol=1e-9):  # absolute: 10^6 m coordinates
            r = r[:-1]
        if len(r) > 1:
            keep = np.r_[True, np.linalg.norm(np.diff(r, axis=0), axis=1) > 1e-9]
            r = r[keep]
        if len(r) >= 3:
            clean.append(r)
        elif not clean:
            return None  # no usable exterior
    if not clean or not np.isfinite(np.vstack(clean)).all():
        return None
    ext = clean[0]
    centre = ext.mean(axis=0)
    rel = ext - centre
    normal = np.sum(np.cross(rel, np.roll(rel, -1, axis=0)), axis=0)
    length = np.linalg.norm(normal)
    if length < 1e-12:
        return None
    normal /= length
    helper = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(helper, normal)
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    points = np.vstack(clean)
    flat = np.column_stack([(points - centre) @ u, (points - centre) @ v])
    ends = np.cumsum([len(r) for r in clean]).astype(np.uint32)
    try:
        idx = np.asarray(mapbox_earcut.triangulate_float64(flat, ends), dtype=np.int64).reshape(-1, 3)
    except Exception:
        return None
    if len(idx) == 0:
        return None
    tri = points[idx]
    # earcut's output winding is not promised: make every triangle face the polygon's normal
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    flip = n @ normal < 0
    tri[flip] = tri[flip][:, ::-1]
    return tri


@dataclass
class CityObject:
    """One top-level city object: id, type, its triangles per LoD, and the LoD chosen."""

    id: str
    kind: str
    name: str | None = None
    by_lod: dict = field(default_factory=dict)  # LoD -> list of (n, 3, 3) triangle arrays
    triangles: list = field(default_factory=list)  # those of the chosen LoD

    def add(self, lod: int, triangles) -> None:
        self.by_lod.setdefault(lod, []).append(triangles)

    def mesh(self) -> trimesh.Trimesh | None:
        if not self.triangles:
            return None
        tri = np.vstack(self.triangles)
        return trimesh.Trimesh(vertices=tri.reshape(-1, 3), faces=np.arange(3 * len(tri)).reshape(-1, 3),
                               process=False)


def pick_lod(available: set, requested: int | None, what: str, path) -> int:
    """The LoD to read: the requested one, else the highest available above 0."""
    usable = {lod for lod in available if lod >= 1}
    if requested is not None:
        if requested < 1:
            raise InputFileError(path, f"unsupported LoD {requested}: footprints have no walls; use LoD 1 or higher")
        if requested not in available:
            raise InputFileError(path, f"{what} has no LoD {requested} geometry "
                                       f"(it has LoD {', '.join(str(x) for x in sorted(available)) or 'none'})")
        return requested
    if not usable:
        raise InputFileError(path, f"{what} has no 3D geometry (LoD 1 or higher); "
                                   f"found LoD {', '.join(str(x) for x in sorted(available)) or 'none'}")
    return max(usable)


def to_source(objects: list[CityObject], path, building: str | None, context_radius: float | None,
              crs: tuple[str | None, str | None], skipped: int, lod: int | None = None) -> MeshSource:
    """The target building and, within ``context_radius`` of it, every other object as obstacle.

    The target is read at ``lod`` (default: its highest LoD of 1 or more); the others at the
    same LoD where they have it, else at their highest.
    """
    with_geometry = [o for o in objects if any(k >= 1 for k in o.by_lod)]
    if lod is not None and lod < 1:
        pick_lod(set(), lod, "the file", path)
    for o in with_geometry:
        o.triangles = o.by_lod[lod if lod in o.by_lod else max(o.by_lod)]
    buildings = [o for o in with_geometry if o.kind in ("Building", "Bridge", "Tunnel")]
    if not with_geometry:
        raise InputFileError(path, "holds no city object with 3D geometry")
    if building is None:
        if len(buildings) == 1:
            target = buildings[0]
        elif len(with_geometry) == 1:
            target = with_geometry[0]
        else:
            raise ParameterError(
                f"{path}: {len(buildings)} buildings; choose one with --building ID "
                f"(for example {', '.join(o.id for o in buildings[:4])})")
    else:
        matches = [o for o in with_geometry if building in (o.id, o.name)]
        if not matches:
            raise ParameterError(
                f"{path}: no city object with id {building!r}; ids in the file include "
                f"{', '.join(o.id for o in buildings[:5] or with_geometry[:5])}")
        target = matches[0]
    chosen = pick_lod(set(target.by_lod), lod, f"{target.kind} {target.id}", path)
    target.triangles = target.by_lod[chosen]
    radius = DEFAULT_CONTEXT_RADIUS if context_radius is None else float(context_radius)
    target_mesh = target.mesh()
    lo, hi = target_mesh.bounds
    meshes = [(target.id, target_mesh)]
    for other in with_geometry:
        if other is target:
            continue
        m = other.mesh()
        olo, ohi = m.bounds
        gap = np.maximum(np.maximum(olo[:2] - hi[:2], lo[:2] - ohi[:2]), 0.0)
        if np.linalg.norm(gap) <= radius:
            meshes.append((other.id, m))
    notes = [f"{path.name}: target {target.kind} {target.id}, {len(meshes) - 1} city objects within "
             f"{radius:g} m as obstacles"]
    if skipped:
        notes.append(f"{path.name}: skipped {skipped} polygons that could not be triangulated")
    horizontal, vertical = crs
    return MeshSource(meshes=meshes, crs=horizontal, target_names=[target.id], notes=notes,
                      vertical_crs=vertical)
