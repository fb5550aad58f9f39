"""Readers and writers behind one registry each, keyed by file extension / format name.

Readers return a :class:`MeshSource` (named meshes in metres, plus CRS if the file has
one); writers take a :class:`~coverplan.route.Route` and a path.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import trimesh

from ..errors import InputFileError


@dataclass
class MeshSource:
    """What a reader found in one file: named meshes and optional georeferencing."""

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

_READERS: dict[str, Reader] = {}
_MISSION_READERS: dict[str, Callable] = {}
_CITY_READERS: dict[str, Callable] = {}
_WRITERS: dict[str, tuple[Writer, str]] = {}


def _by_extension(table: dict, extensions) -> Callable:
    """A decorator entering the function in ``table`` under each extension."""
    def wrap(func):
        for ext in extensions:
            table[ext.lower()] = func
        return func
    return wrap


def register_reader(*extensions: str):
    return _by_extension(_READERS, extensions)


def register_writer(name: str, suffix: str):
    def wrap(func: Writer) -> Writer:
        _WRITERS[name] = (func, suffix)
        return func
    return wrap


def register_city_reader(*extensions: str):
    """Readers of whole city models (CityGML, CityJSON): path -> io.city.CityModel."""
    return _by_extension(_CITY_READERS, extensions)


def register_mission_reader(*extensions: str):
    """Readers of flight-app missions (io/missions.py): path -> Mission."""
    return _by_extension(_MISSION_READERS, extensions)


def mission_extensions() -> list[str]:
    _load_plugins()
    return sorted(_MISSION_READERS)


def read_mission(path):
    """Read a QGroundControl / Mission Planner / Litchi mission; errors name the file."""
    _load_plugins()
    path = Path(path)
    if not path.exists():
        raise InputFileError(path, "no such file")
    if path.is_dir() or path.stat().st_size == 0:
        raise InputFileError(path, "is a directory" if path.is_dir() else "is empty")
    reader = _MISSION_READERS.get(path.suffix.lower().lstrip("."))
    if reader is None:
        raise InputFileError(path, f"is not a route or mission file; give a coverplan route (.json) or a mission: "
                                   f"{', '.join('.' + e for e in mission_extensions())}")
    try:
        return reader(path)
    except UnicodeDecodeError:
        raise InputFileError(path, "is not UTF-8 text") from None


def _extension(path: Path) -> str:
    name = path.name.lower()
    for ext in sorted(_READERS, key=len, reverse=True):
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
    """Read any supported scene file; errors name the file and the problem."""
    _load_plugins()
    path = _readable(path)
    ext = _extension(path)
    reader = _READERS.get(ext)
    if reader is None:
        raise InputFileError(
            path, f"unsupported format '.{ext}'; supported: {', '.join(supported_extensions())}")
    return reader(path, **options)


def read_city_model(path):
    """Read a whole CityGML / CityJSON file once (an io.city.CityModel)."""
    _load_plugins()
    path = _readable(path)
    reader = _CITY_READERS.get(_extension(path))
    if reader is None:
        raise InputFileError(path, "is not a city model; give a CityGML (.gml) or CityJSON (.city.json, "
                                   ".json, .jsonl, optionally .gz) file")
    return reader(path)


def read_json(path, error=InputFileError):
    """The JSON value in a UTF-8 file; ``error`` (an InputFileError class) names the file and
    says what is wrong with it."""
    import json
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise error(path, "is not UTF-8 text") from None
    except json.JSONDecodeError as exc:
        raise error(path, f"is not valid JSON ({exc.msg} at line {exc.lineno})") from None


def open_maybe_gzip(path, mode: str = "rb"):
    """Open a file, decompressing it when its name ends in .gz."""
    import gzip
    path = Path(path)
    if path.name.lower().endswith(".gz"):
        return gzip.open(path, mode) if "b" in mode else gzip.open(path, mode, encoding="utf-8")
    return open(path, mode) if "b" in mode else open(path, mode, encoding="utf-8")


def supported_extensions() -> list[str]:
    _load_plugins()
    return sorted(_READERS)


def writer(name: str) -> tuple[Writer, str]:
    _load_plugins()
    try:
        return _WRITERS[name]
    except KeyError:
        from ..errors import ParameterError
        raise ParameterError(
            f"unknown export format {name!r}; formats: {', '.join(sorted(_WRITERS))}") from None


def writer_names() -> list[str]:
    _load_plugins()
    return sorted(_WRITERS)


GEOGRAPHIC_FORMATS = {"qgc", "wpl", "litchi", "kml", "geojson", "wpml"}  # need the route placed on Earth


def parse_formats(text: str | None) -> list[str]:
    """Export format names from 'qgc,kml' (a ParameterError for unknown ones)."""
    if not text:
        return []
    names = [n.strip().lower() for n in text.split(",") if n.strip()]
    unknown = [n for n in names if n not in writer_names()]
    if unknown:
        from ..errors import ParameterError
        raise ParameterError(f"unknown export format {', '.join(unknown)}; formats: {', '.join(writer_names())}")
    return names


def export_route(route, stem, formats, **options) -> list[Path]:
    """Write ``route`` in each format as STEM + the format's suffix; a route of several battery
    flights as one file per flight, STEM.f1 + suffix, STEM.f2 + suffix, ... Nothing is written
    when a flight has more waypoints than a format's app takes."""
    from ..drones import WAYPOINT_LIMITS
    from ..errors import ParameterError
    flights = [route] if route.n_flights <= 1 else [route.flight_route(k) for k in range(1, route.n_flights + 1)]
    for name in formats:
        limit = WAYPOINT_LIMITS.get(name)
        for k, flight in enumerate(flights, start=1):
            if limit is not None and len(flight) > limit:
                which = f"flight {k} has" if len(flights) > 1 else "the flight has"
                raise ParameterError(f"{which} {len(flight)} waypoints, but {name} missions take at most {limit}; "
                                     "plan shorter flights (--max-flight-min) or export another format")
    written = []
    for name in formats:
        func, suffix = writer(name)
        for k, flight in enumerate(flights, start=1):
            written += func(flight, f"{stem}{'' if len(flights) == 1 else f'.f{k}'}{suffix}", **options)
    return written


def write_atomic(path, text: str) -> Path:
    """Write a text file so readers never see half of it: temporary file, fsync, rename."""
    return write_atomic_bytes(path, text.encode("utf-8"))


def write_atomic_bytes(path, data: bytes) -> Path:
    """Write a file so readers never see half of it: temporary file, fsync, rename."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes it private; give it the usual permissions
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def _load_plugins() -> None:
    # Importing the modules registers their readers and writers.
    from . import citygml, cityjson, csv_waypoints, footprints, geojson, kml, litchi, meshes, qgc, wpml  # noqa: F401
