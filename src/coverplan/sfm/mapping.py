"""COLMAP's mappers: which one a flight gets, its options, and a progress bar while it maps."""

from __future__ import annotations

import os
from pathlib import Path

from coverplan.errors import ParameterError
from coverplan.progress import Progress, clock_bar

MAPPERS = ("auto", "incremental", "global")


# "auto" maps flights of more photos than this with the global mapper: the incremental one
# split the courtyard block's 180- and 335-photo field flights (two and three models) on
# matches that joined every photo, where the global one kept each whole; up to 118 photos
# (Figure 4.11's scene) it passed every field draw (docs/reconstruction.md).
GLOBAL_MAPPING_ABOVE = 150


# Seconds per photo of COLMAP's global mapper on 2 cores: 1.18, 1.36 and 1.13 at 180, 335
# and 1,053 photos (benchmarks/simulate_scale.py). It gives no callback while it runs, so its
# progress bar runs on this estimate.
GLOBAL_MAPPING_S_PER_PHOTO = 1.3


def global_mapping_seconds(photos: int, threads: int = -1) -> int:
    """Estimated seconds COLMAP's global mapper takes for ``photos`` photos on ``threads``
    threads (-1: every core), from the rate measured on 2 cores.

    Parameters
    ----------
    photos : int
        Photos.
    threads : int
        Threads.

    Returns
    -------
    int
        Seconds.
    """
    cores = (os.cpu_count() or 2) if threads is None or threads <= 0 else threads
    return max(1, int(round(GLOBAL_MAPPING_S_PER_PHOTO * photos * 2.0 / max(min(cores, 16), 1))))


def check_mapper(kind: str) -> str:
    """``kind`` if it names a COLMAP mapper (or "auto"), else a one-line error.

    Parameters
    ----------
    kind : str
        ``auto``, ``incremental`` or ``global``.

    Returns
    -------
    str
        ``kind``.

    Raises
    ------
    ParameterError
        For another name.
    """
    if kind not in MAPPERS:
        raise ParameterError(f"unknown mapper {kind!r}; choose one of {', '.join(MAPPERS)}")
    return kind


def pick_mapper(kind: str, photos: int) -> str:
    """The mapper that ``kind`` names for a flight of ``photos`` photos: "auto" is COLMAP's
    incremental mapper up to ``GLOBAL_MAPPING_ABOVE`` photos and its global one above.

    Parameters
    ----------
    kind : str
        ``auto``, ``incremental`` or ``global``.
    photos : int
        Photos.

    Returns
    -------
    str
        ``incremental`` or ``global``.
    """
    check_mapper(kind)
    if kind != "auto":
        return kind
    return "global" if photos > GLOBAL_MAPPING_ABOVE else "incremental"


def set_options(options, overrides: dict | None) -> None:
    """Set ``overrides`` ({dotted attribute path: value}, such as
    ``{"mapper.ba_num_iterations": 1}``) on a pycolmap options object; a one-line error for a
    path it does not have.

    Parameters
    ----------
    options : object
        A pycolmap options object.
    overrides : dict, optional
        Dotted attribute paths to values.

    Raises
    ------
    ParameterError
        For a path the options do not have.
    """
    for path, value in (overrides or {}).items():
        *parents, name = path.split(".")
        obj = options
        try:
            for part in parents:
                obj = getattr(obj, part)
            getattr(obj, name)
            setattr(obj, name, value)
        except (AttributeError, TypeError) as err:
            raise ParameterError(f"COLMAP option {path}={value!r}: {err}") from None


def _map(pycolmap, mapper: str, database: Path, image_dir: Path, sparse: Path, threads: int, seed: int,
         tick, overrides: dict | None = None, refine: bool = False) -> dict:
    """COLMAP's models from the matched database; ``refine``: bundle adjustment refines the
    focal lengths and distortion (never the principal point), else the intrinsics stay as
    given. ``overrides``: options set after ours (``set_options``), for experiments."""
    glob = mapper == "global"
    options = pycolmap.GlobalPipelineOptions() if glob else pycolmap.IncrementalPipelineOptions()
    options.num_threads = threads
    options.random_seed = seed
    options.multiple_models = True
    options.min_model_size = 3
    if glob:
        options.mapper.global_positioning.use_gpu = False
        ba = options.mapper.bundle_adjustment
        ba.refine_focal_length = ba.refine_extra_params = bool(refine)
        ba.refine_principal_point = False
    else:
        options.ba_refine_focal_length = options.ba_refine_extra_params = bool(refine)
        options.ba_refine_principal_point = False
    set_options(options, overrides)
    if glob:
        return pycolmap.global_mapping(database, image_dir, sparse, options=options)
    return pycolmap.incremental_mapping(database, image_dir, sparse, options=options,
                                        next_image_callback=lambda: tick(1))


def map_models(pycolmap, mapper: str, database: Path, image_dir: Path, sparse: Path, threads: int, seed: int,
               photos: int, progress=None, refine: bool = False) -> dict:
    """``_map`` under a progress bar: one step per photo the incremental mapper registers; for
    the global mapper, which reports nothing while it runs, seconds against its estimated time
    (``global_mapping_seconds``).

    Parameters
    ----------
    pycolmap : module
        pycolmap.
    mapper : str
        ``incremental`` or ``global``.
    database : Path
        COLMAP's database.
    image_dir : Path
        The photos.
    sparse : Path
        Where the models are written.
    threads : int
        Threads.
    seed : int
        COLMAP's seed.
    photos : int
        Photos, for the bar.
    progress : Progress, optional
        Draws the bar.
    refine : bool
        Refine the intrinsics.

    Returns
    -------
    dict
        COLMAP's reconstructions by index.
    """
    progress = progress or Progress()
    if mapper == "incremental":
        with progress.stage("SfM mapping", total=photos, unit="img") as tick:
            return _map(pycolmap, mapper, database, image_dir, sparse, threads, seed, tick, refine=refine)
    estimate = global_mapping_seconds(photos, threads)
    with progress.stage("SfM mapping (time estimated)", total=estimate, unit="s") as tick, \
            clock_bar(tick, estimate):
        return _map(pycolmap, mapper, database, image_dir, sparse, threads, seed, tick, refine=refine)
