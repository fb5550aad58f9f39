"""A flight's real photos as a route: their positions, heights and cameras from their tags, in the scene's frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from coverplan.equipment.camera import Camera
from coverplan.errors import InputFileError, ParameterError
from coverplan.flight.missions import AMSL, TAKEOFF, Mission, mission_to_route
from coverplan.geometry import geo
from coverplan.progress import Progress
from coverplan.sfm.cameras import LENS_MODEL, CameraGroup, photo_groups
from coverplan.sfm.photos import PhotoTags, photo_files, raw_files, read_photo, whole_image


def photos_as_mission(tags: list[PhotoTags], absolute_heights: bool, source: str) -> Mission:
    """The photos as a mission of one photo per waypoint, in name order; ``mission.heights``
    says which height each photo gave and in which datum (``photo_heights``).

    Parameters
    ----------
    tags : list of PhotoTags
        The photos' metadata.
    absolute_heights : bool
        The scene's heights have a datum.
    source : str
        What the photos are, for notes.

    Returns
    -------
    Mission
        One waypoint per photo.
    """
    lat = np.array([t.lat for t in tags])
    lon = np.array([t.lon for t in tags])
    alt, ref, heights = photo_heights(tags, absolute_heights)
    mission = Mission(lat, lon, alt, ref, np.array([t.heading_deg for t in tags]),
                      np.array([t.pitch_deg for t in tags]), np.ones(len(tags), dtype=bool), source)
    mission.notes.append(f"heights: {heights}")
    return mission


def photo_heights(tags: list[PhotoTags], absolute_heights: bool) -> tuple[np.ndarray, np.ndarray, str]:
    """Each photo's height and its reference (above take-off or above sea level), and one line
    naming the datum.

    Heights above the take-off point (DJI's ``RelativeAltitude``) are used unless the scene's
    heights have a datum. Then DJI's ``AbsoluteAltitude`` (EGM96 above sea level), or, where
    the photo was taken with RTK fixed (``RtkFlag`` 50), the same tag as a WGS84 ellipsoidal
    height, brought to EGM96 with PROJ's geoid grid; else EXIF ``GPSAltitude`` (above sea level
    as the receiver writes it, its sign from ``GPSAltitudeRef``).

    Parameters
    ----------
    tags : list of PhotoTags
        The photos' metadata.
    absolute_heights : bool
        The scene's heights have a datum.

    Returns
    -------
    alt : (n,) float
        Metres.
    ref : (n,) str
        TAKEOFF or AMSL.
    datum : str
        The line naming it.
    """
    rel = np.array([t.relative_altitude_m for t in tags])
    xmp = np.array([t.absolute_altitude_m for t in tags])
    exif = np.array([t.gps_altitude_m for t in tags])
    rtk = np.array([t.rtk_fixed for t in tags])
    absolute = np.where(np.isfinite(xmp), xmp, exif)
    use_abs = ~np.isfinite(rel) | (absolute_heights & np.isfinite(absolute))
    ellipsoidal = use_abs & rtk & np.isfinite(xmp)
    if ellipsoidal.any():
        lat = np.array([t.lat for t in tags])[ellipsoidal]
        lon = np.array([t.lon for t in tags])[ellipsoidal]
        try:
            geoid = geo.checked_transformer("EPSG:4979", "EPSG:4326+5773")
            _lon, _lat, h = geoid.transform(lon, lat, absolute[ellipsoidal])
        except ParameterError:
            if np.isfinite(rel[ellipsoidal]).all():  # no geoid grid: heights above take-off instead
                use_abs &= ~ellipsoidal
                ellipsoidal[:] = False
            else:
                raise
        else:
            absolute = absolute.copy()
            absolute[ellipsoidal] = np.asarray(h)
    alt = np.where(use_abs, absolute, rel)
    ref = np.where(use_abs, AMSL, TAKEOFF)
    parts = []
    if (~use_abs).any():
        parts.append(f"{int((~use_abs).sum())} above the take-off point (DJI RelativeAltitude)")
    if ellipsoidal.any():
        parts.append(f"{int(ellipsoidal.sum())} RTK fixed: WGS84 ellipsoidal (DJI AbsoluteAltitude) brought to EGM96")
    plain = use_abs & ~ellipsoidal & np.isfinite(xmp)
    if plain.any():
        parts.append(f"{int(plain.sum())} above sea level, EGM96 (DJI AbsoluteAltitude)")
    gps = use_abs & ~np.isfinite(xmp)
    if gps.any():
        parts.append(f"{int(gps.sum())} above sea level as the receiver writes it (EXIF GPSAltitude)")
    return alt, ref, "; ".join(parts)


def route_camera(group: CameraGroup, tags: list[PhotoTags]) -> Camera:
    """The camera of a group of photos as the route takes it (size and field of view).

    Parameters
    ----------
    group : CameraGroup
        The camera as SfM takes it.
    tags : list of PhotoTags
        Its photos' metadata.

    Returns
    -------
    Camera
        The camera.
    """
    photo = group.photo
    mm = [t.focal_mm for t in tags if t.name in set(group.names) and np.isfinite(t.focal_mm)]
    mm = float(np.median(mm)) if mm else 10.0
    return Camera(photo.width / photo.fx * mm, photo.height / photo.fy * mm, mm, photo.width, photo.height,
                  name="from the photos' EXIF")


def photos_route(folder, scene, gsd: float, security: float, progress: Progress | None = None, least: int = 1,
                 lens_model: str = LENS_MODEL):
    """The photos of ``folder`` as a route of one photo per waypoint, in the scene's frame,
    from their metadata (positions through the scene's georeference).

    Parameters
    ----------
    folder : str or Path
        The photos.
    scene : Scene
        The scene, georeferenced.
    gsd : float
        Metres per pixel asked.
    security : float
        Metres.
    progress : Progress, optional
        Reports reading the tags.
    least : int
        Photos with a position needed.
    lens_model : str
        The COLMAP camera model for photos without a calibration.

    Returns
    -------
    route : Route
    tags : list of PhotoTags
        The photos used, in name order.
    left_out : list of (name, why)
        Photos without a position.
    cameras : list of CameraGroup
        The photos' cameras as SfM takes them, the most used first.
    """
    progress = progress or Progress()
    folder = Path(folder)
    files = photo_files(folder)
    if not geo.has_georeference(scene.frame):
        raise ParameterError("the photos give latitude/longitude, but the scene has no georeference: pass --crs "
                             "EPSG:XXXX or --geo-origin LAT LON H (as for planning)")
    left_out = raw_files(folder)
    with progress.stage("reading the photos' metadata", total=len(files), unit="img") as tick:
        tags = []
        for f in files:
            name = f.relative_to(folder).as_posix()  # photos of several flights may share a file name
            try:
                tag = read_photo(f) if whole_image(f) else None
            except InputFileError:
                tag = None
            if tag is None:
                left_out.append((name, "not a whole image (the file is cut short or corrupt)"))
            else:
                tag.name = name
                tags.append(tag)
            tick(1)
    left_out += [(t.name, "no GPS position in its metadata") for t in tags if not t.has_position]
    tags = [t for t in tags if t.has_position]
    if len(tags) < least:
        raise InputFileError(folder, f"has {len(tags)} photo(s) with a GPS position; "
                                     + ("SfM needs at least 2" if least >= 2 else "at least one is needed"))
    cameras = photo_groups(tags, folder, lens_model)
    camera = route_camera(cameras[0], tags)
    frame = scene.frame
    absolute = bool(frame.get("vertical_crs") or frame.get("geodetic_origin"))
    route = mission_to_route(photos_as_mission(tags, absolute, "photos"), scene, camera, gsd, security)
    route.extra["source"] = f"{len(tags)} photos in {folder}"
    route.extra["heights"] = next((n.split(": ", 1)[1] for n in route.extra["notes"] if n.startswith("heights: ")), "")
    return route, tags, left_out, cameras
