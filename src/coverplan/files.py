"""File helpers every layer uses: JSON in, gzip-aware opening, atomic writes, paths relative to a file."""

from __future__ import annotations

import gzip
import json
import math
import os
import tempfile
from pathlib import Path

from coverplan.errors import InputFileError


def read_json(path, error=InputFileError):
    """The JSON value in a UTF-8 file; ``error`` (an InputFileError class) names the file and
    says what is wrong with it.

    Parameters
    ----------
    path : str or Path
        The file to read.
    error : type
        The InputFileError subclass raised when the file is missing or not JSON.

    Returns
    -------
    object
        The decoded JSON value.
    """
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise error(path, "is not UTF-8 text") from None
    except json.JSONDecodeError as exc:
        raise error(path, f"is not valid JSON ({exc.msg} at line {exc.lineno})") from None


def finite(value):
    """``value`` with every NaN or infinite float, however deep in dicts and lists, as None:
    what strict JSON readers (browsers, jq, other languages) accept for "no value".

    Parameters
    ----------
    value : object
        A JSON-like value: dicts, lists, tuples, numpy arrays and numbers.

    Returns
    -------
    object
        The same structure with every non-finite float as None.
    """
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(v) for v in value]
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        return finite(value.tolist())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def json_text(value, indent: int | None = 1) -> str:
    """Strict JSON of ``value``: numpy numbers as numbers, NaN and infinities as null.

    Parameters
    ----------
    value : object
        A JSON-like value (``finite`` is applied first).
    indent : int or None
        Indentation of the text; None writes one line.

    Returns
    -------
    str
        The JSON text.
    """
    return json.dumps(finite(value), indent=indent, allow_nan=False)


def open_maybe_gzip(path, mode: str = "rb"):
    """Open a file, decompressing it when its name ends in .gz.

    Parameters
    ----------
    path : str or Path
        The file; a name ending in ``.gz`` is read or written through gzip.
    mode : str
        ``open``'s mode; text modes use UTF-8.

    Returns
    -------
    file object
        The open file.
    """
    path = Path(path)
    if path.name.lower().endswith(".gz"):
        return gzip.open(path, mode) if "b" in mode else gzip.open(path, mode, encoding="utf-8")
    return open(path, mode) if "b" in mode else open(path, mode, encoding="utf-8")


def write_atomic(path, text: str) -> Path:
    """Write a text file so readers never see half of it: temporary file, fsync, rename.

    Parameters
    ----------
    path : str or Path
        The file to write; its folder must exist.
    text : str
        The content, written as UTF-8.

    Returns
    -------
    Path
        ``path``.
    """
    return write_atomic_bytes(path, text.encode("utf-8"))


def write_atomic_bytes(path, data: bytes) -> Path:
    """Write a file so readers never see half of it: temporary file, fsync, rename.

    Parameters
    ----------
    path : str or Path
        The file to write; its folder must exist.
    data : bytes
        The content.

    Returns
    -------
    Path
        ``path``.
    """
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


def relative_to(record: dict, folder) -> dict:
    """A scene record (io/scene_record.py) with each path relative to ``folder`` where the file
    lies within two levels above it (a project folder that moves as a whole); others absolute.

    Parameters
    ----------
    record : dict
        A scene record whose entries may carry a ``path``.
    folder : str or Path
        The folder the paths are made relative to (the route file's).

    Returns
    -------
    dict
        A new record; ``record`` is not changed.
    """
    def rel(entry):
        if not isinstance(entry, dict) or not isinstance(entry.get("path"), str):
            return None
        try:
            path = os.path.relpath(entry["path"], folder)
        except ValueError:  # another drive (Windows): keep it absolute
            return dict(entry)
        return dict(entry, path=path if Path(path).parts.count("..") <= 2 else entry["path"])
    return _paths_mapped(record, rel)


def absolute_to(record: dict, folder) -> dict:
    """A scene record with each relative path taken from ``folder`` (the inverse of ``relative_to``).

    Parameters
    ----------
    record : dict
        A scene record as ``relative_to`` wrote it.
    folder : str or Path
        The folder its relative paths start from.

    Returns
    -------
    dict
        A new record with absolute paths.
    """
    def absolute(entry):
        if not isinstance(entry, dict) or not isinstance(entry.get("path"), str) or os.path.isabs(entry["path"]):
            return dict(entry) if isinstance(entry, dict) else None
        return dict(entry, path=os.path.normpath(os.path.join(folder, entry["path"])))
    return _paths_mapped(record, absolute)


def _paths_mapped(record: dict, func) -> dict:
    files = record.get("files") if isinstance(record.get("files"), dict) else {}
    return {"files": {k: [func(e) for e in v if isinstance(e, dict) and isinstance(e.get("path"), str)]
                      for k, v in files.items() if isinstance(v, list)},
            "terrain": func(record.get("terrain")), "options": dict(record.get("options", {}))}
