"""Photos already taken, for ``plan --existing``: a folder of tagged photos (read as
``check`` reads them), a route file or a mission file (QGroundControl, Mission Planner,
Litchi, DJI WPML), as ExistingShots in the scene's frame."""

from __future__ import annotations

from pathlib import Path

from coverplan.errors import InputFileError
from coverplan.flight.missions import mission_to_route
from coverplan.flight.route import Route
from coverplan.io.formats import read_mission
from coverplan.sfm.photo_route import photos_route
from coverplan.shots.existing import ExistingShots


def read_existing(path, scene, camera, gsd: float, security: float, progress=None) -> ExistingShots:
    """The photos of ``path`` where they were (or will be) taken.

    A folder holds photos with EXIF GPS and DJI XMP tags (sfm/photos.py); a ``.json`` file is a
    coverplan route; anything else is read as a mission (io/formats.read_mission), photos at
    its photo waypoints, with ``camera``.

    Parameters
    ----------
    path : str or Path
        A photo folder, a route file or a mission file.
    scene : Scene
        Its geodetic origin places the photos' tags.
    camera : Camera
        The camera a mission's photos are taken with.
    gsd : float
        The plan's GSD, m/px, the route the photos become is stamped with.
    security : float
        The plan's security distance, m, likewise.
    progress : Progress, optional
        Bars for reading a large folder.

    Returns
    -------
    ExistingShots
        The photos' poses in the scene's frame, and what they came from.

    Raises
    ------
    InputFileError
        No such file or folder, a route or mission that takes no photos, or a folder
        without photos that carry a position.
    """
    p = Path(path)
    if not p.exists():
        raise InputFileError(p, "no such file or folder")
    if p.is_dir():
        route = photos_route(p, scene, gsd, security, progress)[0]
        return ExistingShots.of_route(route)
    if p.suffix.lower() == ".json":
        route = Route.load(p)
        if not route.shot.any():
            raise InputFileError(p, "takes no photos")
        return ExistingShots.of_route(route, f"{int(route.shot.sum())} photos of the route {p.name}")
    route = mission_to_route(read_mission(p), scene, camera, gsd, security)
    if not route.shot.any():
        raise InputFileError(p, "takes no photos")
    return ExistingShots.of_route(route, f"{int(route.shot.sum())} photos of the {route.extra.get('source', 'mission')} "
                                         f"{p.name}")
