"""Footprints and heights (OpenStreetMap, a cadastre, a hand-drawn GeoJSON) as closed building
meshes: each polygon (holes and multi-polygons too) extruded from the ground (z 0) to its
height, with a flat roof, or a gable roof along the footprint's long axis when a roof-height
attribute gives the ridge above the eaves. The footprints then behave as a city model: pick
the target with ``--building``, and those within ``--context-radius`` are obstacles.

GeoJSON is read directly: RFC 7946 files (longitude, latitude) are projected to their UTM
zone; a legacy "crs" member names a projected CRS in metres. GeoPackage and Shapefile go
through pyogrio (``pip install 'coverplan[footprints]'``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from coverplan.errors import InputFileError, ParameterError
from coverplan.files import read_json
from coverplan.io.city import CityModel, CityObject, parse_crs, triangulate_rings
from coverplan.io.registry import MeshSource, register_reader

EXTENSIONS = ("geojson", "gpkg", "shp")


@register_reader(*EXTENSIONS)
def read_footprints(path, building: str | None = None, context_radius: float | None = None,
                    height_attribute: str | None = None, height: float | None = None,
                    roof_attribute: str | None = None, **_ignored) -> MeshSource:
    """Read one footprint of a GeoJSON, GeoPackage or Shapefile as an extruded building, with its neighbours.

    Parameters
    ----------
    path : str or Path
        The file.
    building : str, optional
        A feature's id or name.
    context_radius : float, optional
        Metres around the building whose footprints are obstacles.
    height_attribute : str, optional
        The attribute holding each building's height.
    height : float, optional
        The height of every building, metres.
    roof_attribute : str, optional
        The attribute holding each gable's height above the eaves.
    **_ignored
        Options of other readers.

    Returns
    -------
    MeshSource
        The target first, then the obstacles.
    """
    model = read_footprint_model(path, height_attribute, height, roof_attribute)
    src = model.source(building, context_radius, None)
    src.stand_on_terrain = True
    return src


def read_footprint_model(path, height_attribute: str | None = None, height: float | None = None,
                         roof_attribute: str | None = None) -> CityModel:
    """Every footprint of the file as an extruded building (a CityModel).

    Parameters
    ----------
    path : str or Path
        The file.
    height_attribute : str, optional
        The attribute holding each building's height.
    height : float, optional
        The height of every building, metres.
    roof_attribute : str, optional
        The attribute holding each gable's height.

    Returns
    -------
    CityModel
        One object per footprint.
    """
    import shapely
    path = Path(path)
    if height_attribute is None and height is None:
        raise ParameterError(f"{path.name} holds footprints: give their height with --height-attribute NAME "
                             "or --height M")
    if height is not None and not (np.isfinite(height) and height > 0):
        raise ParameterError(f"--height must be a positive number of metres, got {height!r}")
    geometries, ids, props, crs = read_features(path)
    geometries, crs = _projected(geometries, crs, path)
    objects = []
    for geom, fid, attrs in zip(geometries, ids, props):
        if geom is None or geom.is_empty or geom.geom_type not in ("Polygon", "MultiPolygon"):
            continue
        h = _number(attrs, height_attribute, fid, path) if height_attribute and height_attribute in attrs else height
        if h is None:
            raise InputFileError(path, f"footprint {fid} has no {height_attribute!r}; give --height M for "
                                       "footprints without one")
        if not (np.isfinite(h) and h > 0):
            raise InputFileError(path, f"footprint {fid} has height {h!r}; heights must be positive metres")
        roof = _number(attrs, roof_attribute, fid, path) if roof_attribute and roof_attribute in attrs else 0.0
        if roof < 0:
            raise InputFileError(path, f"footprint {fid} has roof height {roof!r}; it must be >= 0")
        geom = shapely.make_valid(geom)
        parts = [g for g in getattr(geom, "geoms", [geom]) if g.geom_type == "Polygon" and g.area > 1e-6]
        tri = [extrude(p, float(h), float(roof)) for p in parts]
        if tri:
            obj = CityObject(str(fid), "Building", attrs.get("name"), attributes=attrs)
            obj.add(2 if roof > 0 else 1, np.vstack(tri))
            objects.append(obj)
    if not objects:
        raise InputFileError(path, "holds no polygon footprints")
    return CityModel(path, objects, (crs, None))


def extrude(polygon, height: float, roof: float = 0.0, base: float = 0.0) -> np.ndarray:
    """Triangles (n, 3, 3) of the closed solid over ``polygon``: walls from ``base`` to the
    eaves at ``base + height``, a floor, and a flat roof or, with ``roof`` > 0, a gable whose
    ridge runs along the long axis of the footprint's smallest enclosing rectangle.

    Parameters
    ----------
    polygon : shapely.Polygon
        The footprint.
    height : float
        Eaves above the base, metres.
    roof : float
        The gable's height above the eaves, metres.
    base : float
        The ground's height, metres.

    Returns
    -------
    (n, 3, 3) float
        Triangles.
    """
    import shapely
    from shapely.geometry import LineString
    from shapely.ops import split
    polygon = shapely.geometry.polygon.orient(polygon, 1.0)  # exterior counter-clockwise
    top = _roof_height(polygon, base + height, roof)
    pieces = [polygon]
    if roof > 0:
        centre, along, _across, _half = _axes(polygon)
        reach = 2.0 * np.ptp(np.asarray(polygon.exterior.coords), axis=0).max() + 1.0
        ridge = LineString([centre - reach * along, centre + reach * along])
        pieces = [shapely.geometry.polygon.orient(p, 1.0) for p in split(polygon, ridge).geoms]
    out = []
    for piece in pieces:
        rings = _rings(piece)
        # The floor in the same pieces: its edges then meet the walls' at the ridge crossings.
        floor = triangulate_rings([np.column_stack([r, np.full(len(r), base)]) for r in rings])
        if floor is not None:
            out.append(floor[:, ::-1])  # facing down
        roof_tri = triangulate_rings([np.column_stack([r, top(r)]) for r in rings])
        if roof_tri is not None:
            out.append(roof_tri)
        for ring in rings:
            a, b = ring, np.roll(ring, -1, axis=0)
            # Walls stand on the footprint's outline; the cut along the ridge is inside it.
            wall = shapely.distance(shapely.points((a + b) / 2.0), polygon.boundary) < 1e-6 * max(polygon.length, 1.0)
            a, b = a[wall], b[wall]
            za, zb = top(a), top(b)
            a0, b0 = np.column_stack([a, np.full(len(a), base)]), np.column_stack([b, np.full(len(b), base)])
            a1, b1 = np.column_stack([a, za]), np.column_stack([b, zb])
            out.append(np.stack([a0, b0, b1], axis=1))
            out.append(np.stack([a0, b1, a1], axis=1))
    return np.vstack(out)


def _rings(polygon) -> list[np.ndarray]:
    return [np.asarray(polygon.exterior.coords)[:-1, :2]] + [np.asarray(r.coords)[:-1, :2] for r in polygon.interiors]


def _axes(polygon):
    """Centre, unit long axis, unit short axis and half the short side of the smallest rectangle."""
    rect = np.asarray(polygon.minimum_rotated_rectangle.exterior.coords)[:4, :2]
    e1, e2 = rect[1] - rect[0], rect[2] - rect[1]
    along, across = (e1, e2) if np.linalg.norm(e1) >= np.linalg.norm(e2) else (e2, e1)
    half = np.linalg.norm(across) / 2.0
    return rect.mean(axis=0), along / np.linalg.norm(along), across / np.linalg.norm(across), half


def _roof_height(polygon, eaves: float, roof: float):
    if roof <= 0:
        return lambda pts: np.full(len(pts), eaves)
    centre, _along, across, half = _axes(polygon)
    return lambda pts: eaves + roof * np.clip(1.0 - np.abs((np.asarray(pts) - centre) @ across) / half, 0.0, 1.0)


def _number(attrs, name, fid, path) -> float:
    try:
        return float(attrs[name])
    except (TypeError, ValueError):
        raise InputFileError(path, f"footprint {fid}: {name} is {attrs[name]!r}, not a number") from None


def read_features(path: Path):
    """(shapely geometries, ids, attribute dicts, CRS string or None).

    Parameters
    ----------
    path : Path
        GeoJSON, GeoPackage or Shapefile.

    Returns
    -------
    geometries : list of shapely geometry
    ids : list of str
    attributes : list of dict
    crs : str or None
    """
    import shapely
    if path.suffix.lower() == ".geojson":
        data = read_json(path)
        features = data.get("features") if isinstance(data, dict) and data.get("type") == "FeatureCollection" \
            else [data] if isinstance(data, dict) and data.get("type") == "Feature" else None
        if features is None:
            raise InputFileError(path, "is not a GeoJSON FeatureCollection or Feature")
        crs_name = ((data.get("crs") or {}).get("properties") or {}).get("name")
        crs = parse_crs(crs_name)[0] if crs_name else None
        geoms, ids, props = [], [], []
        for k, f in enumerate(features):
            try:
                geoms.append(shapely.geometry.shape(f["geometry"]) if f.get("geometry") else None)
            except (KeyError, TypeError, ValueError, AttributeError, shapely.errors.GEOSException) as exc:
                raise InputFileError(path, f"feature {k} has an unreadable geometry ({exc})") from None
            attrs = f.get("properties") or {}
            ids.append(f.get("id", attrs.get("id", k)))
            props.append(attrs)
        return geoms, ids, props, crs
    try:
        import pyogrio
    except ImportError:
        raise ParameterError("reading GeoPackage/Shapefile footprints needs pyogrio: "
                             "pip install 'coverplan[footprints]'") from None
    try:
        meta, fids, wkb, fields = pyogrio.raw.read(path)
    except Exception as exc:  # GDAL errors come in many types
        raise InputFileError(path, f"cannot be read as a {path.suffix[1:]} file ({str(exc).splitlines()[0][:120]})") \
            from None
    names = list(meta.get("fields", []))
    props = [{n: (col[k].item() if hasattr(col[k], "item") else col[k]) for n, col in zip(names, fields)}
             for k in range(len(wkb))]
    ids = [p.get("id", int(f) if fids is not None else k) for k, (p, f) in
           enumerate(zip(props, fids if fids is not None else range(len(wkb))))]
    return list(shapely.from_wkb(np.asarray(wkb, dtype=object))), ids, props, meta.get("crs")


def _projected(geometries, crs, path):
    """Geometries in a projected CRS in metres: longitude/latitude go to their UTM zone."""
    import shapely
    from pyproj import CRS, Transformer
    source = CRS.from_user_input(crs) if crs else CRS.from_epsg(4326)  # RFC 7946: WGS84 degrees
    if not source.is_geographic:
        if source.axis_info and source.axis_info[0].unit_name not in ("metre", "meter"):
            raise InputFileError(path, f"is in {source.name}, whose unit is {source.axis_info[0].unit_name}; "
                                       "reproject it to a CRS in metres")
        epsg = source.to_epsg()
        return geometries, f"EPSG:{epsg}" if epsg else source.to_string()
    live = [g for g in geometries if g is not None and not g.is_empty]
    if not live:
        raise InputFileError(path, "holds no polygon footprints")
    lon, lat = shapely.union_all(live).centroid.coords[0]
    utm = 32600 + int((lon + 180) // 6) + 1 if lat >= 0 else 32700 + int((lon + 180) // 6) + 1
    to_utm = Transformer.from_crs(source, CRS.from_epsg(utm), always_xy=True)
    moved = [None if g is None else shapely.transform(g, lambda xy: np.column_stack(to_utm.transform(xy[:, 0], xy[:, 1])))
             for g in geometries]
    return moved, f"EPSG:{utm}"
