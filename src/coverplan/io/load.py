"""load_scene: scene files (meshes, city models, footprints, point clouds, a DTM) into a Scene."""

from __future__ import annotations

from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from coverplan.errors import InputFileError, ParameterError
from coverplan.geometry.geo import check_crs
from coverplan.io.formats import read_file
from coverplan.io.registry import MeshSource
from coverplan.io.scene_record import file_hash, scene_record
from coverplan.world.dtm import TERRAIN_MARGIN_M, read_dtm
from coverplan.world.merge import unite_overlapping_targets
from coverplan.world.pointcloud import point_obstacle
from coverplan.world.scene import UNITS, MeshPart, Scene, build_scene
from coverplan.world.terrain import Terrain


def _part_name(path, raw: str, many: bool) -> str:
    stem = Path(path).name.split(".")[0] or Path(path).stem
    return f"{stem}:{raw}" if many else stem


def load_scene(targets: str | Path | MeshSource | Sequence[str | Path | MeshSource],
               obstacles: Iterable[str | Path] = (),
               *, units: str | None = None, ground: float | None = None,
               target_names: Sequence[str] | None = None,
               up_axis: str | None = None, building: str | None = None,
               lod: int | None = None, context_radius: float | None = None,
               crs: str | None = None, geodetic_origin: Sequence[float] | None = None,
               obstacle_points: Iterable[str | Path] = (), points_resolution: float = 0.5,
               point_classes: Sequence[int] | None = None, height_attribute: str | None = None,
               height: float | None = None, roof_attribute: str | None = None,
               terrain: str | Path | None = None) -> Scene:
    """Read target and obstacle files into a Scene in metres.

    Far-away coordinates are moved to a local origin (kept in ``Scene.origin``); the local frame
    has x east, y north, z up.

    Parameters
    ----------
    targets : path, MeshSource or sequence of them
        Target files: meshes (OBJ, PLY, STL, OFF, GLB/glTF), CityGML / CityJSON, footprints
        (GeoJSON, GeoPackage, Shapefile); or a MeshSource already read (``coverplan batch``
        reads a city file once).
    obstacles : iterable of path
        Obstacle mesh files, in the targets' coordinates.
    units : {"m", "cm", "mm", "ft", "in"}, optional
        Units of the mesh files (default: the CRS's unit, else m).
    ground : float, optional
        Ground height in metres in the source frame (default: the target's lowest point).
    target_names : sequence of str, optional
        In multi-object target files (GLB, OBJ), the objects that are targets; the file's
        other objects become obstacles.
    up_axis : {"y", "z"}, optional
        Up axis of the mesh files (default z; glTF/GLB y).
    building : str, optional
        CityGML / CityJSON: the id of the target building.
    lod : int, optional
        CityGML / CityJSON: the level of detail (default: the highest).
    context_radius : float, optional
        CityGML / CityJSON: city objects within this distance (m) become obstacles (default 150).
    crs : str, optional
        The projected CRS (``"EPSG:25832"``) of mesh coordinates that carry none.
    geodetic_origin : (3,) float, optional
        Or [lat, lon, h] (degrees, degrees, m) of a local (east, north, up) mesh frame's origin.
    obstacle_points : iterable of path
        LAS / LAZ / PLY point clouds in the meshes' coordinates; their occupied voxels become
        obstacles.
    points_resolution : float
        Voxel size (m) the point clouds are turned into obstacles at.
    point_classes : sequence of int, optional
        LAS classes to keep (default: all but ground 2 and noise 7, 18).
    height_attribute : str, optional
        Footprints: the attribute with each building's height (m).
    height : float, optional
        Footprints: the height (m) of those without the attribute, or of all.
    roof_attribute : str, optional
        Footprints: the ridge height above the eaves (m), for a gable roof (default flat).
    terrain : path, optional
        A DTM raster (GeoTIFF, any CRS pyproj knows, heights in the models' height system);
        without it a city model's relief makes the terrain, and without that the ground is flat
        at ``ground``.

    Returns
    -------
    Scene
        Targets, obstacles and ground in the local frame, with the georeference and the notes
        on what preparing the meshes changed.

    Raises
    ------
    InputFileError
        A file is missing, unreadable or holds no mesh.
    ParameterError
        Contradicting or impossible options (a CRS and a geodetic origin, unknown units).

    Examples
    --------
    >>> import coverplan
    >>> scene = coverplan.load_scene("meshes/gabled_house.obj")
    >>> [part.role for part in scene.parts]
    ['target']
    >>> round(float(scene.ground_z), 2)
    0.0
    """
    obstacles, obstacle_points = list(obstacles), list(obstacle_points)
    if crs is not None and geodetic_origin is not None:
        raise ParameterError("give either a CRS or a geodetic origin, not both")
    user_crs = None if crs is None else check_crs(crs)
    if geodetic_origin is not None:
        geodetic_origin = _check_geodetic_origin(geodetic_origin)
    if isinstance(targets, (str, Path, MeshSource)):
        targets = [targets]
    targets = list(targets)
    if not targets:
        raise ParameterError("give at least one target mesh")
    if units is not None and units not in UNITS:
        raise ParameterError(f"unknown units {units!r}; use one of {', '.join(UNITS)}")
    options = {"up_axis": up_axis, "building": building, "lod": lod, "context_radius": context_radius,
               "height_attribute": height_attribute, "height": height, "roof_attribute": roof_attribute}
    parts: list[MeshPart] = []
    notes: list[str] = []
    crs = vertical = None
    file_of_crs = None
    wanted = set(target_names or ())
    found: set[str] = set()
    available: set[str] = set()
    if terrain is not None and ground is not None:
        raise ParameterError("give either --terrain or --ground: the terrain is the ground")
    ground_tri = []  # a city model's ground objects, in source coordinates
    lifted = set()  # names of parts to stand on the terrain (extruded footprints)
    for path in targets:
        src = path if isinstance(path, MeshSource) else read_file(path, **options)
        path = src.path or path
        notes += src.notes
        if src.ground is not None:
            ground_tri.append(src.ground)
        if src.stand_on_terrain:
            lifted |= {_part_name(path, raw, len(src.meshes) > 1) for raw, _m in src.meshes}
        if src.crs and crs and src.crs != crs:
            raise ParameterError(f"{path} is in {src.crs} but {file_of_crs} is in {crs}; convert one of them")
        if src.crs and not crs:
            crs, file_of_crs = src.crs, path
        vertical = vertical or src.vertical_crs
        chosen = set(src.target_names) if src.target_names else (wanted or None)
        many = len(src.meshes) > 1
        for raw, mesh in src.meshes:
            available.add(raw)
            role = "target" if chosen is None or raw in chosen else "obstacle"
            if role == "target":
                found.add(raw)
            parts.append(MeshPart(_part_name(path, raw, many), role, mesh, str(path)))
    missing = wanted - found
    if missing:
        raise ParameterError(f"no object named {', '.join(sorted(missing))} in the target files; "
                             f"objects: {', '.join(sorted(available)[:12])}")
    for path in obstacles:
        src = read_file(path, **options)
        notes += src.notes
        if src.ground is not None:
            ground_tri.append(src.ground)
        many = len(src.meshes) > 1
        if src.stand_on_terrain:
            lifted |= {_part_name(path, raw, many) for raw, _m in src.meshes}
        parts += [MeshPart(_part_name(path, raw, many), "obstacle", mesh, str(path)) for raw, mesh in src.meshes]
    if user_crs and crs and user_crs != crs:
        raise ParameterError(f"--crs {user_crs} contradicts {file_of_crs}, which says {crs}")
    # Units: as given, else the CRS's, else metres; a CRS and --units that disagree is an error.
    crs_unit = _crs_unit(crs or user_crs)
    factor = UNITS[units] if units is not None else (crs_unit or 1.0)
    if crs_unit is not None and abs(crs_unit - factor) > 1e-9 * crs_unit:
        named = [k for k, v in UNITS.items() if abs(v - crs_unit) < 1e-6]
        raise ParameterError(f"--units {units} contradicts {crs or user_crs}, whose unit is "
                             f"{named[0] if named else f'{crs_unit:g} m'}; drop --units")
    if factor != 1.0 and crs_unit is not None and units is None:
        notes.append(f"coordinates scaled by {factor:g}: the unit of {crs or user_crs}")
    for path in obstacle_points:
        mesh, note = point_obstacle(path, points_resolution / factor, point_classes)  # voxels in metres
        notes.append(note)
        parts.append(MeshPart(f"points '{Path(path).name}'", "obstacle", mesh, str(path)))
    for part in parts:
        part.mesh.apply_scale(factor)
    if geodetic_origin is not None and crs:
        raise ParameterError(f"{file_of_crs} is georeferenced ({crs}); a geodetic origin would contradict it")
    ground_m = None if ground is None else float(ground)
    scene = build_scene(parts, ground=ground_m, crs=crs or user_crs, vertical_crs=vertical, notes=notes)
    scene.geodetic_origin = geodetic_origin
    scene.crs_unit_m = factor if (crs or user_crs) else 1.0
    scene.terrain, terrain_notes = _load_terrain(scene, terrain, ground_tri if terrain is None else [], factor)
    if scene.terrain is not None:
        terrain_notes += _stand_on_terrain(scene, lifted)
        # the flat stand-in, for pictures: the lowest ground under the target
        lo, hi = scene.bounds("target")
        scene.ground_z = scene.terrain.lowest_in(lo[:2], hi[:2])
    scene.notes += terrain_notes + unit_warnings(scene, units or "m")
    scene.source = scene_record(
        {"targets": targets, "obstacles": list(obstacles), "obstacle_points": list(obstacle_points),
         "terrain": terrain},
        dict(options, units=units, ground=ground, target_names=target_names, crs=user_crs,
             geodetic_origin=geodetic_origin, points_resolution=points_resolution if obstacle_points else None,
             point_classes=point_classes))
    return unite_overlapping_targets(scene)


CITY_TERRAIN_STEP_M = 1.0  # grid of a city model's ground surfaces


def scene_from_record(record: dict, route_path):
    """Load the scene a route records, its paths taken relative to the route's folder.

    Parameters
    ----------
    record : dict
        The route file's ``scene`` record.
    route_path : str or Path
        The route file.

    Returns
    -------
    Scene
        The scene.

    Raises
    ------
    InputFileError
        When a recorded file is not where the route says (named with the option that replaces
        it) or no longer the file the route was planned on.
    """
    route_path = Path(route_path)
    folder = route_path.parent

    def found(entry, flag):
        path = Path(entry["path"])
        path = path if path.is_absolute() else folder / path
        if not path.exists():
            raise InputFileError(route_path, f"its scene file {entry['path']} is not there (moved?); give the scene "
                                             f"with {flag}")
        if entry.get("sha256") and file_hash(path) != entry["sha256"]:
            raise InputFileError(route_path, f"its scene file {path} has changed since the route was planned; "
                                             f"give the scene with {flag} to judge the route against it as it is")
        return str(path)

    files = record.get("files", {})
    targets = [found(e, "--target") for e in files.get("targets", [])]
    if not targets:
        raise InputFileError(route_path, "records no scene; give it with --target")
    options = dict(record.get("options", {}))
    merge = options.pop("merge_obstacles_within", None)
    terrain = record.get("terrain")
    scene = load_scene(targets, [found(e, "--obstacles") for e in files.get("obstacles", [])],
                       obstacle_points=[found(e, "--obstacle-points") for e in files.get("obstacle_points", [])],
                       terrain=None if terrain is None else found(terrain, "--terrain"), **options)
    if merge is not None:
        from coverplan.world.merge import merge_into_target
        scene = merge_into_target(scene, merge)
    return scene


def _stand_on_terrain(scene: Scene, names: set) -> list[str]:
    """Lift meshes extruded from z 0 so each stands on the lowest ground along its outline
    (a footprint's height counts from its lowest ground contact)."""
    moved = 0
    for part in scene.parts:
        if part.name not in names:
            continue
        v = part.mesh.vertices
        base = v[:, 2].min()
        outline = v[np.abs(v[:, 2] - base) < 1e-6]
        part.mesh.apply_translation([0.0, 0.0, float(scene.terrain.height(outline[:, :2]).min()) - base])
        moved += 1
    return [f"{moved} footprint buildings stand on the terrain (walls from the lowest ground along each outline)"] \
        if moved else []


def _load_terrain(scene: Scene, path, ground_tri: list, factor: float) -> tuple[Terrain | None, list[str]]:
    """The scene's terrain from a DTM file or a city model's ground triangles (or None)."""
    if path is None and not ground_tri:
        return None, []
    lo, hi = scene.bounds()
    if path is not None:
        if scene.geodetic_origin is not None:
            raise ParameterError("--terrain needs models in a projected CRS (--crs), not a geodetic origin")
        terrain, notes = read_dtm(path, scene.crs, scene.origin, (lo[:2] + scene.origin[:2]) / factor,
                                  (hi[:2] + scene.origin[:2]) / factor, factor)
    else:
        tri = np.vstack(ground_tri) * factor - scene.origin
        have_lo, have_hi = tri.reshape(-1, 3)[:, :2].min(axis=0), tri.reshape(-1, 3)[:, :2].max(axis=0)
        box_lo = np.maximum(lo[:2] - TERRAIN_MARGIN_M, have_lo)
        box_hi = np.minimum(hi[:2] + TERRAIN_MARGIN_M, have_hi)
        if (box_hi - box_lo <= 0).any():
            return None, ["the city model's ground objects do not reach the target; the ground is flat"]
        terrain = Terrain.from_triangles(tri, box_lo, box_hi, CITY_TERRAIN_STEP_M, "the city model's ground")
        notes = []
    ny, nx = terrain.shape
    notes.append(f"terrain from {terrain.source}: {nx} x {ny} heights every {terrain.dx:.2g} m, "
                 f"ground {terrain.heights.min() + scene.origin[2]:.1f}..{terrain.heights.max() + scene.origin[2]:.1f} m")
    return terrain, notes


def unit_warnings(scene: Scene, units: str) -> list[str]:
    """Warn when the target's size suggests the units are wrong (a 20 km tall building...).

    Parameters
    ----------
    scene : Scene
        The scene.
    units : str
        The units the files were read in.

    Returns
    -------
    list of str
        Warnings; empty when the size is plausible.
    """
    size = np.ptp(scene.bounds("target"), axis=0)
    height, width = float(size[2]), float(size[:2].max())
    biggest = max(height, width)
    if biggest > 2000:
        guess = "mm" if biggest > 20000 else "cm"
        return [f"WARNING: the target is {width:,.0f} m wide and {height:,.0f} m tall; if the file is in "
                f"{'millimetres' if guess == 'mm' else 'centimetres'}, pass --units {guess}"]
    if biggest < 1.0:
        return [f"WARNING: the target is only {biggest:.3f} m across"
                + ("; if the file is in metres, drop --units" if units != "m" else "; check --units")]
    return []


def _crs_unit(crs: str | None) -> float | None:
    """Metres per unit of a projected CRS's horizontal axes (None without a CRS)."""
    if not crs:
        return None
    from pyproj import CRS
    try:
        axis = CRS.from_user_input(crs).axis_info
    except Exception:
        return None
    return float(axis[0].unit_conversion_factor) if axis else None


def _check_geodetic_origin(values) -> list[float]:
    try:
        lat, lon, h = (float(v) for v in values)
    except (TypeError, ValueError):
        raise ParameterError(f"geodetic origin must be LAT LON H, got {values!r}") from None
    if not (-90 <= lat <= 90 and -180 <= lon <= 180 and np.isfinite(h)):
        raise ParameterError(f"geodetic origin {lat} {lon} {h} is not on Earth (latitude, longitude in degrees)")
    return [lat, lon, h]
