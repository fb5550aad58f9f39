"""CityGML 1.0-3.0 (GML 3.1.1 and 3.2): top-level city objects as meshes, LoD by LoD.

Polygons are collected under every ``lodN...`` geometry property of an object and its parts
(boundary surfaces, building parts, installations, openings), ``xlink:href`` references
resolved, each polygon counted once per LoD. Rings come from ``gml:posList``, ``gml:pos`` or
``gml:coordinates``; holes are kept.
"""

from __future__ import annotations

import re
import zlib

import numpy as np
from lxml import etree

from coverplan.errors import InputFileError
from coverplan.files import open_maybe_gzip
from coverplan.io.city import CityModel, CityObject, parse_crs, triangulate_rings
from coverplan.io.registry import MeshSource, register_city_reader, register_reader

GML_NAMESPACES = ("http://www.opengis.net/gml/3.2", "http://www.opengis.net/gml")
XLINK = "{http://www.w3.org/1999/xlink}href"
_LOD = re.compile(r"^lod(\d)")
_SURFACES = {"Polygon", "Triangle", "Rectangle"}


def _local(element) -> str:
    return etree.QName(element).localname if isinstance(element.tag, str) else ""


EXTENSIONS = ("gml", "citygml", "xml", "gml.gz", "citygml.gz", "xml.gz")


@register_reader(*EXTENSIONS)
def read_citygml(path, building: str | None = None, lod: int | None = None,
                 context_radius: float | None = None, **_ignored) -> MeshSource:
    """Read one building of a CityGML file and its neighbours (the reader of .gml and .xml).

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
    return read_citygml_model(path).source(building, context_radius, lod)


@register_city_reader(*EXTENSIONS)
def read_citygml_model(path) -> CityModel:
    """Every top-level city object of a CityGML file.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    CityModel
        Its objects.
    """
    parser = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=True, remove_comments=True)
    try:
        with open_maybe_gzip(path) as handle:
            root = etree.parse(handle, parser).getroot()
    except etree.XMLSyntaxError as exc:
        raise InputFileError(path, f"is not well-formed XML ({exc.msg})") from None
    except (OSError, EOFError, zlib.error) as exc:
        raise InputFileError(path, f"cannot be read ({exc})") from None
    if _local(root) != "CityModel":
        raise InputFileError(path, f"is not CityGML: the root element is <{_local(root) or '?'}>, not <CityModel>")
    gml = next((ns for ns in GML_NAMESPACES if ns in root.nsmap.values()), None)
    if gml is None:
        gml = next((ns for ns in GML_NAMESPACES if root.find(f".//{{{ns}}}Polygon") is not None), GML_NAMESPACES[0])
    gml_id = f"{{{gml}}}id"
    srs = next((e.get("srsName") for e in root.iter() if isinstance(e.tag, str) and e.get("srsName")), None)
    crs = parse_crs(srs)
    by_id = {e.get(gml_id): e for e in root.iter() if isinstance(e.tag, str) and e.get(gml_id)}

    objects, skipped = [], 0
    members = [m for m in root.iter() if _local(m) == "cityObjectMember"]
    for member in members:
        for obj in member:
            if not isinstance(obj.tag, str):
                continue
            name_el = obj.find(f"{{{gml}}}name")
            city = CityObject(obj.get(gml_id) or f"{_local(obj)}{len(objects)}", _local(obj),
                              name_el.text.strip() if name_el is not None and name_el.text else None,
                              attributes=_attributes(obj))
            seen_by_lod: dict[int, set] = {}  # per LoD: a Solid's shell often refers to boundary polygons
            for prop in obj.iter():
                match = _LOD.match(_local(prop))
                if not match:
                    continue
                level = int(match.group(1))
                seen = seen_by_lod.setdefault(level, set())
                for surface in _surfaces(prop, by_id, gml):
                    if id(surface) in seen:
                        continue
                    seen.add(id(surface))
                    tri = triangulate_rings(_rings(surface, gml, path))
                    if tri is None:
                        skipped += 1
                    else:
                        city.add(level, tri)
            if not city.by_lod and _local(obj) in RELIEF_KINDS:
                _add_relief(city, obj, gml, path)
            objects.append(city)
    if not objects:
        raise InputFileError(path, "holds no city objects (no cityObjectMember)")
    return CityModel(path, objects, crs, skipped)


RELIEF_KINDS = ("ReliefFeature", "TINRelief")


def _add_relief(city: CityObject, obj, gml, path) -> None:
    """A relief's triangles: its geometry hangs under ``tin`` / ``reliefComponent``, not under
    ``lodN...`` properties, and its LoD is a ``lod`` element."""
    lod_text = next((e.text for e in obj.iter() if _local(e) == "lod" and e.text and e.text.strip().isdigit()), "1")
    for surface in obj.iter(*(f"{{{gml}}}{s}" for s in _SURFACES)):
        tri = triangulate_rings(_rings(surface, gml, path))
        if tri is not None:
            city.add(int(lod_text), tri)


def _attributes(obj) -> dict:
    """Simple attributes of a city object: text-only child elements (bldg:function, ...) and
    generic attributes (CityGML 1/2 ``gen:stringAttribute name=``, 3.0 ``gen:name``/``gen:value``)."""
    found = {}
    for child in obj:
        if not isinstance(child.tag, str):
            continue
        name = _local(child)
        if len(child) == 0 and child.text and child.text.strip():
            found.setdefault(name, child.text.strip())
    for element in obj.iter():
        if not isinstance(element.tag, str) or not _local(element).lower().endswith("attribute"):
            continue
        key = element.get("name")
        parts = {_local(c): (c.text or "").strip() for c in element if isinstance(c.tag, str)}
        key = key or parts.get("name")
        if key and "value" in parts:
            found.setdefault(key, parts["value"])
    return found


def _surfaces(prop, by_id, gml):
    """Polygon-like elements under a geometry property, following xlink:href references."""
    stack = [prop]
    visited = set()
    while stack:
        element = stack.pop()
        if id(element) in visited:
            continue
        visited.add(id(element))
        href = element.get(XLINK)
        if href and href.startswith("#") and href[1:] in by_id:
            stack.append(by_id[href[1:]])
        if element.tag in {f"{{{gml}}}{s}" for s in _SURFACES}:
            yield element
            continue
        stack.extend(child for child in element if isinstance(child.tag, str))


def _rings(surface, gml, path) -> list[np.ndarray]:
    rings = []
    for tag in ("exterior", "interior", "outerBoundaryIs", "innerBoundaryIs"):
        for boundary in surface.findall(f"{{{gml}}}{tag}"):
            ring = boundary.find(f"{{{gml}}}LinearRing")
            if ring is not None:
                rings.append((tag in ("exterior", "outerBoundaryIs"), _coordinates(ring, gml, path)))
    rings.sort(key=lambda r: not r[0])  # exterior first
    return [r for _, r in rings]


def _coordinates(ring, gml, path) -> np.ndarray:
    pos_list = ring.find(f"{{{gml}}}posList")
    try:
        if pos_list is not None:
            dim = int(pos_list.get("srsDimension") or ring.get("srsDimension") or 3)
            values = np.array((pos_list.text or "").split(), dtype=float)
        else:
            positions = ring.findall(f"{{{gml}}}pos")
            if positions:
                rows = [np.array((p.text or "").split(), dtype=float) for p in positions]
                dim = len(rows[0]) if rows else 3
                values = np.concatenate(rows) if rows else np.zeros(0)
            else:
                coords = ring.find(f"{{{gml}}}coordinates")
                text = (coords.text or "") if coords is not None else ""
                rows = [np.array(t.split(","), dtype=float) for t in text.split()]
                dim = len(rows[0]) if rows else 3
                values = np.concatenate(rows) if rows else np.zeros(0)
    except ValueError:
        return np.zeros((0, 3))
    if dim != 3 or len(values) % 3:
        return np.zeros((0, 3))  # 2D or broken rings cannot make a 3D surface
    return values.reshape(-1, 3)
