"""A building's outputs, written atomically, and the rows of buildings done in an earlier run."""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path

RESULT = "result.json"  # written last into a building's folder: its presence means complete


def write_building(out_dir: Path, row: dict, files: dict[str, bytes]) -> Path:
    """Put a building's files in OUT/buildings/FOLDER atomically: a temporary folder with
    ``result.json`` written last, renamed into place.

    Parameters
    ----------
    out_dir : Path
        The batch's output folder.
    row : dict
        The building's summary row (its ``folder`` names the destination).
    files : dict of str to bytes
        The building's output files.

    Returns
    -------
    Path
        The building's folder.
    """
    parent = out_dir / "buildings"
    parent.mkdir(parents=True, exist_ok=True)
    final = parent / row["folder"]
    tmp = Path(tempfile.mkdtemp(prefix=f".{row['folder']}.", suffix=".tmp", dir=parent))
    try:
        sizes = {}
        for name, data in files.items():
            with open(tmp / name, "wb") as handle:
                handle.write(data)
                handle.flush()
                os.fsync(handle.fileno())
            sizes[name] = len(data)
        record = dict(row, files=sizes)
        with open(tmp / RESULT, "w", encoding="utf-8") as handle:
            json.dump(record, handle, indent=1, default=float)
            handle.flush()
            os.fsync(handle.fileno())
        os.chmod(tmp, 0o755)
        if final.exists():  # an older or failed attempt: replaced whole, never mixed with the new one
            old = final.with_name(f".{final.name}.{os.getpid()}.old")
            os.replace(final, old)
            os.replace(tmp, final)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, final)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return final


def completed_row(out_dir: Path, folder: str, key: str) -> dict | None:
    """The recorded row of a building whose folder is complete and valid for ``key``, else None.

    Parameters
    ----------
    out_dir : Path
        The batch's output folder.
    folder : str
        The building's folder name.
    key : str
        The fingerprint the row must have been written under.

    Returns
    -------
    dict or None
        The row from ``result.json``.
    """
    record_path = out_dir / "buildings" / folder / RESULT
    try:
        record = json.loads(record_path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or record.get("status") != "planned" or record.get("key") != key:
        return None
    files = record.get("files")
    if not isinstance(files, dict) or "route.json" not in files:
        return None
    for name, size in files.items():
        path = record_path.parent / name
        if not path.is_file() or path.stat().st_size != size:
            return None
    try:
        json.loads((record_path.parent / "route.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    record.pop("files")
    return record
