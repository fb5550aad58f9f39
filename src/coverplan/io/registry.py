"""The one registry of readers and writers, keyed by file extension / format name.

Reader and writer modules enter themselves here with the ``register_*`` decorators;
:mod:`coverplan.io.formats` imports them all and looks formats up.
Readers return a :class:`MeshSource` (named meshes in metres, plus CRS if the file has
one); writers take a :class:`~coverplan.flight.route.Route` and a path.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import trimesh


@dataclass
class MeshSource:
    """What a reader found in one file: named meshes and optional georeferencing.

    Parameters
    ----------
    meshes : list of (str, trimesh.Trimesh)
        Named meshes.
    crs : str, optional
        Their coordinates' CRS.
    target_names : list of str, optional
        The names that are targets; every mesh when None.
    notes : list of str
        What the reader did.
    vertical_crs : str, optional
        The heights' datum.
    path : Path, optional
        The file read.
    ground : (n, 3, 3) float, optional
        Ground triangles read with the file.
    stand_on_terrain : bool
        Place the meshes on the terrain (footprints without heights).
    """

    meshes: list[tuple[str, trimesh.Trimesh]]
    crs: str | None = None
    # names of meshes the file itself marks as the target (e.g. the chosen building)
    target_names: list[str] | None = None
    notes: list[str] = field(default_factory=list)
    vertical_crs: str | None = None  # heights' datum, when the file names one
    path: Path | None = None  # the file it came from, when handed on already read
    ground: np.ndarray | None = None  # (n, 3, 3) triangles of the ground (a city model's relief, roads...)
    stand_on_terrain: bool = False  # meshes built from z 0 (extruded footprints): lift each onto the terrain


Reader = Callable[..., MeshSource]
Writer = Callable[..., list[Path]]

READERS: dict[str, Reader] = {}
MISSION_READERS: dict[str, Callable] = {}
CITY_READERS: dict[str, Callable] = {}
ZONE_READERS: dict[str, Callable] = {}
WRITERS: dict[str, tuple[Writer, str]] = {}
WriterCheck = Callable[..., str | None]
WRITER_CHECKS: dict[str, WriterCheck] = {}


def _by_extension(table: dict, extensions) -> Callable:
    """A decorator entering the function in ``table`` under each extension."""
    def wrap(func):
        for ext in extensions:
            table[ext.lower()] = func
        return func
    return wrap


def register_reader(*extensions: str):
    """Enter a scene reader for files ending in ``extensions``.

    Parameters
    ----------
    *extensions : str
        Extensions without the dot.

    Returns
    -------
    callable
        A decorator.
    """
    return _by_extension(READERS, extensions)


def register_writer(name: str, suffix: str, check: WriterCheck | None = None):
    """Enter a writer of format ``name`` (files end in ``suffix``). ``check(flight, **options)``
    says why one flight does not fit the app or autopilot the format is for (None: it fits);
    ``export_route`` asks it of every flight before it writes the format.

    Parameters
    ----------
    name : str
        The format's name.
    suffix : str
        Its files' suffix.
    check : callable, optional
        ``check(flight, **options)``.

    Returns
    -------
    callable
        A decorator.
    """
    def wrap(func: Writer) -> Writer:
        WRITERS[name] = (func, suffix)
        if check is not None:
            WRITER_CHECKS[name] = check
        return func
    return wrap


def register_city_reader(*extensions: str):
    """Readers of whole city models (CityGML, CityJSON): path -> io.city.CityModel.

    Parameters
    ----------
    *extensions : str
        Extensions without the dot.

    Returns
    -------
    callable
        A decorator.
    """
    return _by_extension(CITY_READERS, extensions)


def register_mission_reader(*extensions: str):
    """Readers of flight-app missions (flight/missions.py): path -> Mission.

    Parameters
    ----------
    *extensions : str
        Extensions without the dot.

    Returns
    -------
    callable
        A decorator.
    """
    return _by_extension(MISSION_READERS, extensions)


def register_zone_reader(*extensions: str):
    """Readers of keep-out / keep-in zones (io/zones.py): (path, kind, scene) -> list of Zone.

    Parameters
    ----------
    *extensions : str
        Extensions without the dot.

    Returns
    -------
    callable
        A decorator.
    """
    return _by_extension(ZONE_READERS, extensions)
