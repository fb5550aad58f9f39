"""Which of COLMAP's stages a work folder already holds, so that a rerun of ``check`` resumes.

A stage is kept only when it finished (its key is written after it) and its key, made from
everything it read (the photos' names, sizes and times, the cameras, the options; for
matching also the features' key), is the one the rerun would use. A killed or failed stage
left no key, so it runs again; a changed photo or option clears it and every stage after.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np

STAGES_FILE = "stages.json"


def stage_key(*parts) -> str:
    """A digest of ``parts``, equal only for equal inputs.

    Parameters
    ----------
    *parts : numbers, strings, lists or arrays
        What a stage read; arrays by their float64 bytes, the rest as JSON.

    Returns
    -------
    str
        The SHA-256 hex digest.
    """
    digest = hashlib.sha256()
    for part in parts:
        if isinstance(part, np.ndarray):
            digest.update(np.ascontiguousarray(part, dtype=float).tobytes())
        else:
            digest.update(json.dumps(part, sort_keys=True, default=str).encode())
        digest.update(b"\x00")
    return digest.hexdigest()


def photo_stamps(image_dir: Path, names: list[str]) -> list[tuple[str, int, int]]:
    """Each photo's name, size and modification time: a photo written again differs.

    Parameters
    ----------
    image_dir : Path
        The photos' folder.
    names : list of str
        Their paths inside it.

    Returns
    -------
    list of (str, int, int)
        Name, size (bytes), modification time (ns).
    """
    stamps = []
    for name in names:
        status = (Path(image_dir) / name).stat()
        stamps.append((name, int(status.st_size), int(status.st_mtime_ns)))
    return stamps


class WorkFolder:
    """COLMAP's work folder, with the stages (in order) it holds from an earlier run.

    Parameters
    ----------
    path : Path
        The folder; made if missing, emptied unless the first stage is kept.
    keys : dict of str to str
        Each stage's key (``stage_key``), in the order the stages run.
    resume : bool
        Keep the finished stages whose keys match; False empties the folder.
    """

    def __init__(self, path: Path, keys: dict[str, str], resume: bool):
        self.path = Path(path)
        self.keys = dict(keys)
        finished = self._finished() if resume else {}
        self.kept: list[str] = []
        for stage, key in self.keys.items():
            if finished.get(stage) != key:
                break
            self.kept.append(stage)
        if not self.kept and self.path.exists():
            shutil.rmtree(self.path)
        self.path.mkdir(parents=True, exist_ok=True)
        self._write()  # stages after the kept ones are no longer finished

    def _finished(self) -> dict:
        try:
            return json.loads((self.path / STAGES_FILE).read_text())
        except (OSError, ValueError):
            return {}

    def _write(self) -> None:
        text = json.dumps({stage: self.keys[stage] for stage in self.kept}, indent=1)
        (self.path / STAGES_FILE).write_text(text)

    def has(self, stage: str) -> bool:
        """Whether ``stage`` finished in an earlier run with the inputs of this one.

        Parameters
        ----------
        stage : str
            One of the ``keys``.

        Returns
        -------
        bool
        """
        return stage in self.kept

    def finished(self, stage: str) -> None:
        """Record that ``stage`` finished, so a rerun keeps it.

        Parameters
        ----------
        stage : str
            One of the ``keys``.
        """
        if stage not in self.kept:
            self.kept.append(stage)
        self._write()
