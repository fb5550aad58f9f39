"""File helpers every layer uses: JSON in, gzip-aware opening, atomic writes, paths relative to a file."""

from __future__ import annotations

import gzip
import json
import os
import tempfile
from pathlib import Path

from coverplan.errors import InputFileError


def read_json(path, error=InputFileError):
    """The JSON value in a UTF-8 file; ``error`` (an InputFileError class) names the file and
    says what is wrong with it."""
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise error(path, "is not UTF-8 text") from None
    except json.JSONDecodeError as exc:
        raise error(path, f"is not valid JSON ({exc.msg} at line {exc.lineno})") from None


def open_maybe_gzip(path, mode: str = "rb"):
    """Open a file, decompressing it when its name ends in .gz."""
    path = Path(path)
    if path.name.lower().endswith(".gz"):
        return gzip.open(path, mode) if "b" in mode else gzip.open(path, mode, encoding="utf-8")
    return open(path, mode) if "b" in mode else open(path, mode, encoding="utf-8")


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


def relative_to(record: dict, folder) -> dict:
    """A scene record (io/scene_record.py) with each path relative to ``folder`` where it can be (same drive)."""
    def rel(entry):
        if entry is None:
            return None
        try:
            return dict(entry, path=os.path.relpath(entry["path"], folder))
        except ValueError:  # another drive (Windows): keep it absolute
            return dict(entry)
    return {"files": {k: [rel(e) for e in v] for k, v in record["files"].items()},
            "terrain": rel(record.get("terrain")), "options": dict(record.get("options", {}))}
