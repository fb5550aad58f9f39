"""Formats by name: the registry's readers and writers looked up, and routes exported.

Importing this module imports every reader and writer module, which enters them in
:mod:`coverplan.io.registry`.
"""

from __future__ import annotations

import os
from pathlib import Path

from coverplan.errors import InputFileError, ParameterError
from coverplan.io import (  # noqa: F401
    citygml,
    cityjson,
    csv_waypoints,
    footprints,
    geojson,
    kml,
    litchi,
    meshes,
    qgc,
    wpml,
    zones,
)
from coverplan.io.registry import (
    CITY_READERS,
    MISSION_READERS,
    READERS,
    WRITER_CHECKS,
    WRITERS,
    MeshSource,
    Writer,
)


def mission_extensions() -> list[str]:
    """The file extensions ``check`` and ``plan --existing`` read missions from.

    Returns
    -------
    list of str
        Sorted.
    """
    return sorted(MISSION_READERS)


def read_mission(path):
    """Read a QGroundControl / Mission Planner / Litchi mission; errors name the file.

    Parameters
    ----------
    path : str or Path
        A mission file.

    Returns
    -------
    Mission
        The flight as the app flies it.

    Raises
    ------
    InputFileError
        When the file is missing, of an unknown kind or malformed.
    """
    path = Path(path)
    if not path.exists():
        raise InputFileError(path, "no such file")
    if path.is_dir() or path.stat().st_size == 0:
        raise InputFileError(path, "is a directory" if path.is_dir() else "is empty")
    reader = MISSION_READERS.get(path.suffix.lower().lstrip("."))
    if reader is None:
        raise InputFileError(path, f"is not a route or mission file; give a coverplan route (.json) or a mission: "
                                   f"{', '.join('.' + e for e in mission_extensions())}")
    try:
        return reader(path)
    except UnicodeDecodeError:
        raise InputFileError(path, "is not UTF-8 text") from None


def _extension(path: Path) -> str:
    name = path.name.lower()
    for ext in sorted(READERS, key=len, reverse=True):
        if name.endswith("." + ext):
            return ext
    return path.suffix.lower().lstrip(".")


def _readable(path) -> Path:
    path = Path(path)
    if not path.exists():
        raise InputFileError(path, "no such file")
    if path.is_dir():
        raise InputFileError(path, "is a directory, not a mesh file")
    if not os.access(path, os.R_OK):
        raise InputFileError(path, "cannot be read (permission denied)")
    if path.stat().st_size == 0:
        raise InputFileError(path, "is empty")
    return path


def read_file(path, **options) -> MeshSource:
    """Read any supported scene file; errors name the file and the problem.

    Parameters
    ----------
    path : str or Path
        A scene file.
    **options
        The reader's options (``load_scene``'s keyword arguments).

    Returns
    -------
    MeshSource
        Named meshes and georeferencing.

    Raises
    ------
    InputFileError
        When the file is missing, of an unknown kind or malformed.
    """
    path = _readable(path)
    ext = _extension(path)
    reader = READERS.get(ext)
    if reader is None:
        raise InputFileError(
            path, f"unsupported format '.{ext}'; supported: {', '.join(supported_extensions())}")
    return reader(path, **options)


def read_city_model(path):
    """Read a whole CityGML / CityJSON file once (an io.city.CityModel).

    Parameters
    ----------
    path : str or Path
        A CityGML or CityJSON file.

    Returns
    -------
    CityModel
        Every object.

    Raises
    ------
    InputFileError
        When the file is missing or not a city model.
    """
    path = _readable(path)
    reader = CITY_READERS.get(_extension(path))
    if reader is None:
        raise InputFileError(path, "is not a city model; give a CityGML (.gml) or CityJSON (.city.json, "
                                   ".json, .jsonl, optionally .gz) file")
    return reader(path)


def supported_extensions() -> list[str]:
    """The file extensions scenes are read from.

    Returns
    -------
    list of str
        Sorted.
    """
    return sorted(READERS)


def writer(name: str) -> tuple[Writer, str]:
    """The writer of an export format and its file suffix.

    Parameters
    ----------
    name : str
        A format's name (``writer_names``).

    Returns
    -------
    writer : callable
        ``writer(route, path, **options)``.
    suffix : str
        The files' suffix.
    """
    try:
        return WRITERS[name]
    except KeyError:
        raise ParameterError(
            f"unknown export format {name!r}; formats: {', '.join(sorted(WRITERS))}") from None


def writer_names() -> list[str]:
    """The export formats.

    Returns
    -------
    list of str
        Sorted.
    """
    return sorted(WRITERS)


GEOGRAPHIC_FORMATS = {"qgc", "wpl", "litchi", "kml", "geojson", "wpml"}  # need the route placed on Earth


def parse_formats(text: str | None) -> list[str]:
    """Export format names from 'qgc,kml' (a ParameterError for unknown ones).

    Parameters
    ----------
    text : str or None
        Comma-separated names.

    Returns
    -------
    list of str
        The names, in the order given.

    Raises
    ------
    ParameterError
        Naming an unknown format and listing the known ones.
    """
    if not text:
        return []
    names = [n.strip().lower() for n in text.split(",") if n.strip()]
    unknown = [n for n in names if n not in writer_names()]
    if unknown:
        raise ParameterError(f"unknown export format {', '.join(unknown)}; formats: {', '.join(writer_names())}")
    return names


def _misfit(check, flights, options) -> str | None:
    """Why the first flight that does not fit a format's check does not (None: all fit)."""
    for k, flight in enumerate(flights, start=1):
        why = None if check is None else check(flight, **options)
        if why:
            return f"{f'flight {k} has' if len(flights) > 1 else 'the flight has'} {why}"
    return None


def export_route(route, stem, formats, refused: list | None = None, **options) -> list[Path]:
    """Write ``route`` in each format as STEM + the format's suffix; a route of several battery
    flights as one file per flight, STEM.f1 + suffix, STEM.f2 + suffix, ...

    A format a flight does not fit (its writer's check: more waypoints than DJI WPML numbers,
    more mission items than PX4 keeps) is written for no flight. With ``refused`` (a list), the
    other formats are written all the same and ``(format, reason)`` is appended to it for each
    one left out; without it, any such format raises ParameterError before a file is written.

    Parameters
    ----------
    route : Route
        The route.
    stem : str or Path
        The files' path without the suffix.
    formats : sequence of str
        Format names.
    refused : list, optional
        Collects ``(format, reason)`` of each format left out.
    **options
        The writers' options (``drone``, ``speed``, ``firmware``, ``wpml_heights``, ...).

    Returns
    -------
    list of Path
        The files written.
    """
    flights = [route] if route.n_flights <= 1 else [route.flight_route(k) for k in range(1, route.n_flights + 1)]
    fitting = []
    for name in formats:
        why = _misfit(WRITER_CHECKS.get(name), flights, options)
        if why is None:
            fitting.append(name)
        elif refused is None:
            raise ParameterError(why)
        else:
            refused.append((name, why))
    written = []
    for name in fitting:
        func, suffix = writer(name)
        for k, flight in enumerate(flights, start=1):
            written += func(flight, f"{stem}{'' if len(flights) == 1 else f'.f{k}'}{suffix}", **options)
    return written
