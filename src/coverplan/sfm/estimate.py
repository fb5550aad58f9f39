"""How long ``simulate`` will take, told before it starts: each stage's rate per photo (or per
matched pair) as measured on 2 cores (benchmarks/README.md, "simulate's time estimate"),
scaled by the photo size, the features per photo and the cores."""

from __future__ import annotations

import os

from coverplan.sfm.mapping import pick_mapper

# Seconds on 2 cores at 640 px and 4,096 features per photo (the --quick preset): the gabled
# house (52 photos, exhaustive matching, incremental mapper) and the ring prism (229 photos,
# 20 spatial neighbours, global mapper); the house at 1024 px and 8,192 features gave the
# exponents (matching 3.5x, incremental mapping 3.1x for twice the features).
RENDER_S_PER_PHOTO = 0.18
FEATURES_S_PER_PHOTO = 0.24
MATCH_S_PER_PAIR = 0.023
INCREMENTAL_S = 0.05  # times photos ** 1.3
GLOBAL_S_PER_PHOTO = 0.41
REFERENCE_PX, REFERENCE_FEATURES = 640, 4096


def matched_pairs(photos: int, exhaustive_limit: int, neighbours: int) -> int:
    """Pairs COLMAP matches: every pair up to ``exhaustive_limit`` photos, else about three
    quarters of each photo's ``neighbours`` (pairs found from both ends count once).

    Parameters
    ----------
    photos : int
        Photos in the flight.
    exhaustive_limit : int
        Up to this many, every pair is matched.
    neighbours : int
        Spatial matching's neighbours per photo.

    Returns
    -------
    int
    """
    if photos <= exhaustive_limit:
        return photos * (photos - 1) // 2
    return int(0.75 * photos * min(neighbours, photos - 1))


def simulate_seconds(photos: int, *, draws: int, width: int, max_features: int, neighbours: int,
                     mapper: str = "auto", exhaustive_limit: int = 80, threads: int = -1) -> float:
    """Estimated wall-clock seconds of ``simulate`` for ``photos`` photos.

    Parameters
    ----------
    photos : int
        Photos per draw (the route's and those it was planned around).
    draws : int
        Flights drawn (each rendered and reconstructed on its own).
    width : int
        Photo width in px; rendering and features scale with the pixels.
    max_features : int
        SIFT features per photo; matching scales with their count to the power 1.8, the
        incremental mapper to 1.6, the global one with the count.
    neighbours : int
        Spatial matching's neighbours per photo, above ``exhaustive_limit`` photos.
    mapper : {"auto", "incremental", "global"}
        The COLMAP mapper.
    exhaustive_limit : int
        Photos up to which every pair is matched.
    threads : int
        Threads for COLMAP (-1: every core); the rates are for 2.

    Returns
    -------
    float
        Seconds; within a factor of about 1.5 on the sample scenes (the host and COLMAP's
        run-to-run variation decide the rest).
    """
    cores = (os.cpu_count() or 2) if threads is None or threads <= 0 else threads
    speedup = max(min(cores, 16), 1) / 2.0
    pixels = (width / REFERENCE_PX) ** 2
    features = max_features / REFERENCE_FEATURES
    render = RENDER_S_PER_PHOTO * pixels * photos
    extract = FEATURES_S_PER_PHOTO * pixels * photos
    match = MATCH_S_PER_PAIR * features ** 1.8 * matched_pairs(photos, exhaustive_limit, neighbours)
    if pick_mapper(mapper, photos) == "global":
        mapping = GLOBAL_S_PER_PHOTO * features * photos
    else:
        mapping = INCREMENTAL_S * features ** 1.6 * photos ** 1.3
    return draws * (render + (extract + match + mapping) / speedup)
