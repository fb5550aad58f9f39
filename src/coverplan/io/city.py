"""What CityGML and CityJSON readers share: CRS strings, polygon triangulation, picking the
target building and the city objects around it that become obstacles."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import mapbox_earcut
import numpy as np
import trimesh

from coverplan.errors import InputFileError, ParameterError
from coverplan.io.registry import MeshSource

DEFAULT_CONTEXT_RADIUS = 150.0
BUILDING_KINDS = ("Building", "Bridge", "Tunnel")
# City objects that are the ground itself: they become the terrain, not obstacles.
GROUND_KINDS = ("TINRelief", "ReliefFeature", "Road", "Railway", "Square", "TransportSquare", "Track",
                "Waterway", "LandUse", "WaterBody")
_EPSG = re.compile(r"EPSG(?:/|:)+(?:[0-9.]+[:/])?(\d{4,6})", re.IGNORECASE)


def parse_crs(text: str | None) -> tuple[str | None, str | None]:
    """(horizontal, vertical) 'EPSG:n' codes from an srsName / referenceSystem string.

    Handles 'EPSG:25832', 'urn:ogc:def:crs:EPSG::25832', OGC URLs
    '.../def/crs/EPSG/0/7415' and compound URNs 'urn:ogc:def:crs,crs:EPSG:6.12:3068,crs:EPSG:6.12:5783'.

    Parameters
    ----------
    text : str or None
        The file's srsName or referenceSystem.

    Returns
    -------
    horizontal, vertical : str or None
        ``EPSG:n`` codes.
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

    Parameters
    ----------
    rings : list of (k, 3) float
        The polygon's rings.

    Returns
    -------
    (n, 3, 3) float or None
        Triangles.
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
    """One top-level city object: id, type, name, its triangles per LoD and its attributes.

    Parameters
    ----------
    id : str
        The object's id in the file.
    kind : str
        Its CityGML / CityJSON type (Building, BuildingPart, ...).
    name : str, optional
        Its name.
    by_lod : dict of int to list of (n, 3, 3) float
        Triangles per level of detail.
    attributes : dict
        Its attributes.
    """

    id: str
    kind: str
    name: str | None = None
    by_lod: dict = field(default_factory=dict)  # LoD -> list of (n, 3, 3) triangle arrays
    attributes: dict = field(default_factory=dict)  # the file's attributes of it, for --where

    def add(self, lod: int, triangles) -> None:
        """Add triangles at a level of detail.

        Parameters
        ----------
        lod : int
            The level of detail.
        triangles : (n, 3, 3) float
            File coordinates.
        """
        self.by_lod.setdefault(lod, []).append(triangles)


def pick_lod(available: set, requested: int | None, what: str, path) -> int:
    """The LoD to read: the requested one, else the highest available above 0.

    Parameters
    ----------
    available : set of int
        The levels the object has.
    requested : int or None
        The level asked for (``--lod``).
    what : str
        The object, for the message.
    path : str or Path
        The file, for the message.

    Returns
    -------
    int
        The level.

    Raises
    ------
    InputFileError
        When the requested level is missing or the object has no geometry above LoD 0.
    """
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


@dataclass
class CityModel:
    """Every city object of one CityGML/CityJSON file, read once: pick targets, neighbours,
    footprints from it as often as needed (``coverplan batch`` plans many buildings of it).

    Parameters
    ----------
    path : Path
        The file read.
    objects : list of CityObject
        Every top-level object.
    crs : (str or None, str or None)
        Horizontal and vertical CRS.
    skipped : int
        Objects without usable geometry.
    _bounds, _ground : dict
        Caches.
    """

    path: Path
    objects: list[CityObject]
    crs: tuple[str | None, str | None] = (None, None)
    skipped: int = 0  # polygons that could not be triangulated
    _bounds: dict = field(default_factory=dict, repr=False)  # LoD -> (n, 4) xy bounds
    _ground: dict = field(default_factory=dict, repr=False)  # LoD -> ground objects' triangles, (n, 4) xy bounds

    @property
    def with_geometry(self) -> list[CityObject]:
        """The objects that have geometry at LoD 1 or above."""
        return [o for o in self.objects if any(k >= 1 for k in o.by_lod)]

    @property
    def buildings(self) -> list[CityObject]:
        """Objects one would plan a flight around: buildings, bridges, tunnels with 3D geometry."""
        return [o for o in self.with_geometry if o.kind in BUILDING_KINDS]

    def find(self, building: str) -> CityObject:
        """The object whose id (or name) is ``building``; a ParameterError listing ids if none.

        Parameters
        ----------
        building : str
            An id or a name.

        Returns
        -------
        CityObject
            The object.

        Raises
        ------
        ParameterError
            When no object has that id or name.
        """
        for o in self.with_geometry:
            if building in (o.id, o.name):
                return o
        raise ParameterError(
            f"{self.path}: no city object with id {building!r}; ids in the file include "
            f"{', '.join(o.id for o in self.buildings[:5] or self.with_geometry[:5])}")

    def triangles(self, obj: CityObject, lod: int | None) -> np.ndarray:
        """(n, 3, 3) triangles of ``obj`` at ``lod`` where it has it, else at its highest LoD.

        Parameters
        ----------
        obj : CityObject
            The object.
        lod : int or None
            The level of detail.

        Returns
        -------
        (n, 3, 3) float
            File coordinates.
        """
        return np.vstack(obj.by_lod[lod if lod in obj.by_lod else max(obj.by_lod)])

    def xy_bounds(self, lod: int | None) -> np.ndarray:
        """(n, 4) [xmin, ymin, xmax, ymax] of every object with geometry, in that order.

        Parameters
        ----------
        lod : int or None
            The level of detail.

        Returns
        -------
        (n, 4) float
            File coordinates.
        """
        if lod not in self._bounds:
            boxes = [(t := self.triangles(o, lod).reshape(-1, 3))[:, :2].min(axis=0).tolist()
                     + t[:, :2].max(axis=0).tolist() for o in self.with_geometry]
            self._bounds[lod] = np.asarray(boxes, dtype=float).reshape(-1, 4)
        return self._bounds[lod]

    def ground_near(self, lo, hi, radius: float, lod: int | None) -> list[np.ndarray]:
        """Triangles of the ground objects (any LoD: a relief at LoD 0 still has heights)
        within ``radius`` of the xy box [lo, hi].

        Parameters
        ----------
        lo, hi : (2,) float
            The box's corners, file coordinates.
        radius : float
            Metres.
        lod : int or None
            Unused by the ground, kept for symmetry with the buildings.

        Returns
        -------
        list of (n, 3, 3) float
            Triangles per ground object.
        """
        if lod not in self._ground:  # gathered once per LoD: a batch asks for every building
            tris = [self.triangles(o, lod) for o in self.objects if o.kind in GROUND_KINDS and o.by_lod]
            boxes = [np.r_[t.reshape(-1, 3)[:, :2].min(axis=0), t.reshape(-1, 3)[:, :2].max(axis=0)] for t in tris]
            self._ground[lod] = (tris, np.asarray(boxes, dtype=float).reshape(-1, 4))
        tris, boxes = self._ground[lod]
        return [t for t, near in zip(tris, _within(boxes, lo, hi, radius)) if near]

    def footprint(self, obj: CityObject, lod: int | None = None):
        """The object's outline seen from above (a shapely polygon), in file coordinates.

        Parameters
        ----------
        obj : CityObject
            The object.
        lod : int, optional
            The level of detail.

        Returns
        -------
        shapely.Polygon or shapely.MultiPolygon
            The outline.
        """
        import shapely
        tri = self.triangles(obj, lod)[:, :, :2]
        polygons = shapely.polygons(tri)
        polygons = polygons[shapely.area(polygons) > 1e-6]  # walls project to slivers
        if not len(polygons):
            return shapely.box(*tri.reshape(-1, 2).min(axis=0), *tri.reshape(-1, 2).max(axis=0))
        return shapely.union_all(polygons, grid_size=1e-3).buffer(0)

    def source(self, building: str | None = None, context_radius: float | None = None,
               lod: int | None = None) -> MeshSource:
        """The target building and, within ``context_radius`` of it, every other object as obstacle.

        Parameters
        ----------
        building : str, optional
            An id or a name; the file's only building when None.
        context_radius : float, optional
            Metres; no obstacles when None.
        lod : int, optional
            The level of detail.

        Returns
        -------
        MeshSource
            The target first, then the obstacles.
        """
        return self.neighbourhood(building, context_radius, lod).source()

    def neighbourhood(self, building: str | None = None, context_radius: float | None = None,
                      lod: int | None = None) -> "Neighbourhood":
        """The target building's triangles and those of every object within ``context_radius``.

        The target is read at ``lod`` (default: its highest LoD of 1 or more); the others at the
        same LoD where they have it, else at their highest.

        Parameters
        ----------
        building : str, optional
            An id or a name; the file's only building when None.
        context_radius : float, optional
            Metres; no neighbours when None.
        lod : int, optional
            The level of detail.

        Returns
        -------
        Neighbourhood
            Raw triangles of the building and its neighbours.
        """
        with_geometry = self.with_geometry
        if lod is not None and lod < 1:
            pick_lod(set(), lod, "the file", self.path)
        if not with_geometry:
            raise InputFileError(self.path, "holds no city object with 3D geometry")
        buildings = self.buildings
        if building is None:
            if len(buildings) == 1:
                target = buildings[0]
            elif len(with_geometry) == 1:
                target = with_geometry[0]
            else:
                raise ParameterError(
                    f"{self.path}: {len(buildings)} buildings; choose one with --building ID "
                    f"(for example {', '.join(o.id for o in buildings[:4])})")
        else:
            target = self.find(building)
        chosen = pick_lod(set(target.by_lod), lod, f"{target.kind} {target.id}", self.path)
        radius = DEFAULT_CONTEXT_RADIUS if context_radius is None else float(context_radius)
        boxes = self.xy_bounds(lod)
        tri = np.vstack(target.by_lod[chosen])
        lo, hi = tri.reshape(-1, 3)[:, :2].min(axis=0), tri.reshape(-1, 3)[:, :2].max(axis=0)
        near = _within(boxes, lo, hi, radius)
        parts = [(target.id, tri)]
        nearby = [o for o, keep in zip(with_geometry, near) if keep and o is not target]
        parts += [(o.id, self.triangles(o, lod)) for o in nearby if o.kind not in GROUND_KINDS]
        ground = self.ground_near(lo, hi, radius, lod)
        name = Path(self.path).name
        notes = [f"{name}: target {target.kind} {target.id}, {len(parts) - 1} city objects within "
                 f"{radius:g} m as obstacles"]
        if ground:
            notes.append(f"{name}: terrain from {len(ground)} ground objects (relief, roads, land use)")
        if self.skipped:
            notes.append(f"{name}: skipped {self.skipped} polygons that could not be triangulated")
        return Neighbourhood(parts, notes, self.crs, Path(self.path), np.vstack(ground) if ground else None)


@dataclass
class Neighbourhood:
    """A target building (first of ``parts``) and the city objects around it, as raw triangles:
    small to send to a batch worker, which makes the meshes.

    Parameters
    ----------
    parts : list of (str, (n, 3, 3) float)
        Name and triangles of each object, the target first.
    notes : list of str
        What was read.
    crs : (str or None, str or None)
        Horizontal and vertical CRS.
    path : Path
        The city file.
    ground : (m, 3, 3) float, optional
        Triangles of the ground objects around it.
    """

    parts: list  # (id, (n, 3, 3) triangles), the target first
    notes: list[str]
    crs: tuple[str | None, str | None]
    path: Path
    ground: np.ndarray | None = None  # (n, 3, 3) triangles of the ground objects around it

    def source(self) -> MeshSource:
        """The meshes of the building and its neighbours, as a reader returns them.

        Returns
        -------
        MeshSource
            The target first, then the obstacles.
        """
        meshes = [(oid, _mesh(tri)) for oid, tri in self.parts]
        return MeshSource(meshes=meshes, crs=self.crs[0], target_names=[self.parts[0][0]], notes=list(self.notes),
                          vertical_crs=self.crs[1], path=self.path, ground=self.ground)

    def digest(self) -> str:
        """Changes when any triangle of the target or its neighbours does.

        Returns
        -------
        str
            16 hex digits.
        """
        import hashlib
        h = hashlib.sha256()
        for oid, tri in self.parts + ([("ground", self.ground)] if self.ground is not None else []):
            h.update(oid.encode())
            h.update(np.ascontiguousarray(tri, dtype=np.float64).tobytes())
        return h.hexdigest()[:16]


def _within(boxes, lo, hi, radius: float) -> np.ndarray:
    """Which (n, 4) xy boxes come within ``radius`` of the box [lo, hi]."""
    gap = np.maximum(np.maximum(boxes[:, :2] - hi, lo - boxes[:, 2:]), 0.0)
    return np.linalg.norm(gap, axis=1) <= radius


def _mesh(tri: np.ndarray) -> trimesh.Trimesh:
    return trimesh.Trimesh(vertices=tri.reshape(-1, 3), faces=np.arange(3 * len(tri)).reshape(-1, 3),
                           process=False)
