"""COLMAP's database: features and matches written by one pycolmap call each, their bars following
the rows COLMAP writes, and the photos' recorded positions as pose priors.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def write_position_priors(pycolmap, database: Path, names: list[str], positions: np.ndarray, sigma_m: float) -> None:
    """Each photo's recorded position (its GNSS tag, local metres) as a COLMAP pose prior.

    COLMAP's feature extraction already stores a prior (in WGS84) for every photo whose EXIF
    carries GPS, and the database keeps one prior per image: that one is replaced, not joined
    by a second.

    Parameters
    ----------
    pycolmap : module
        pycolmap.
    database : Path
        COLMAP's database.
    names : list of str
        Photo names.
    positions : (n, 3) float
        Recorded positions, local metres.
    sigma_m : float
        Their standard deviation.
    """
    db = open_database(pycolmap, database)
    try:
        index = {name: k for k, name in enumerate(names)}
        stored = {_data_key(p.corr_data_id): p for p in db.read_all_pose_priors()}
        cov = np.eye(3) * float(sigma_m) ** 2
        for image in db.read_all_images():
            k = index.get(image.name)
            if k is None:
                continue
            prior = stored.get(_data_key(image.data_id))
            fresh = prior is None
            if fresh:
                prior = pycolmap.PosePrior()
                prior.corr_data_id = image.data_id
            prior.position = np.asarray(positions[k], dtype=float)
            prior.position_covariance = cov
            prior.coordinate_system = pycolmap.PosePriorCoordinateSystem.CARTESIAN
            if fresh:
                db.write_pose_prior(prior)
            else:
                db.update_pose_prior(prior)
    finally:
        db.close()


def _data_key(data_id) -> tuple:
    """A hashable key of a COLMAP data id (sensor and the image it belongs to)."""
    sensor = data_id.sensor_id
    return (int(sensor.type.value) if hasattr(sensor.type, "value") else str(sensor.type), int(sensor.id),
            int(data_id.id))


def _clear_matches(pycolmap, database: Path) -> None:
    """Drop the matches a run stopped during matching left half written."""
    db = open_database(pycolmap, database)
    try:
        db.clear_matches()
        db.clear_two_view_geometries()
    finally:
        db.close()


POLL_S = 1.0  # seconds between reads of COLMAP's database for a bar's progress


def open_database(pycolmap, database: Path):
    """COLMAP's database at ``database``, opened as the installed pycolmap opens it.

    Parameters
    ----------
    pycolmap : module
        pycolmap.
    database : Path
        The file.

    Returns
    -------
    pycolmap.Database
        The open database.
    """
    return pycolmap.Database.open(database) if hasattr(pycolmap.Database, "open") else pycolmap.Database(database)


# Rows are counted in a child process: a second SQLite library in COLMAP's own process shares
# its POSIX locks, so closing that connection can reset the WAL index COLMAP has mapped (seen:
# COLMAP's matcher killed by SIGBUS).
_COUNT_ROWS = ("import sqlite3, sys\n"
               "con = sqlite3.connect('file:' + sys.argv[1] + '?mode=ro', uri=True, timeout=0.2)\n"
               "print(con.execute('SELECT COUNT(*) FROM ' + sys.argv[2]).fetchone()[0])\n")


def _rows(database: Path, table: str) -> int | None:
    """Rows in a table of COLMAP's database while COLMAP writes it (None if it is busy)."""
    import subprocess
    import sys

    try:
        out = subprocess.run([sys.executable, "-c", _COUNT_ROWS, str(database), table], capture_output=True,
                             text=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return int(out.stdout) if out.returncode == 0 and out.stdout.strip().isdigit() else None


def polled(pycolmap, call, database: Path, table: str, total: int, tick, base: int = 0) -> None:
    """Run ``call(token)`` (one pycolmap call that fills ``table`` of ``database``, given a
    pycolmap CancellationToken) in a thread and ``tick`` as its rows appear, up to ``total``.
    One call, not many small ones: on 47 photos, 20 calls took 53 s to extract features and
    50 s to match that one call does in 37 s each (every call starts its threads and loads its
    photos' descriptors again). If the caller is interrupted (Ctrl-C) the token is cancelled
    and the call waited for before the interruption goes on.

    Parameters
    ----------
    pycolmap : module
        pycolmap.
    call : callable
        ``call(token)``.
    database : Path
        COLMAP's database.
    table : str
        The table counted.
    total : int
        Rows expected.
    tick : callable
        ``tick(n)``.
    base : int
        Rows already in it.
    """
    import threading

    token = pycolmap.CancellationToken()
    failed = []

    def run():
        try:
            call(token)
        except BaseException as exc:  # re-raised in the caller's thread
            failed.append(exc)

    worker = threading.Thread(target=run, daemon=True)
    worker.start()
    shown = 0
    try:
        while worker.is_alive():
            worker.join(POLL_S)
            rows = _rows(database, table) if database.exists() else None
            rows = None if rows is None else rows - base
            if rows is not None and min(rows, total) > shown:
                tick(min(rows, total) - shown)
                shown = min(rows, total)
    except BaseException:
        token.cancel()
        worker.join()
        raise
    if failed:
        raise failed[0]
    if total > shown:
        tick(total - shown)


def extract_features(pycolmap, database: Path, image_dir: Path, names: list[str], reader, extraction,
                     tick=lambda _n=1: None, base: int = 0) -> None:
    """SIFT features of the photos ``names`` into ``database``, on one camera (the photos share
    the intrinsics ``reader`` gives), ``tick`` per photo done; ``base``: photos already in it.

    Parameters
    ----------
    pycolmap : module
        pycolmap.
    database : Path
        COLMAP's database.
    image_dir : Path
        The photos.
    names : list of str
        Photo names.
    reader : pycolmap.ImageReaderOptions
        The camera.
    extraction : pycolmap.FeatureExtractionOptions
        SIFT options.
    tick : callable
        ``tick(n)``.
    base : int
        Photos already in the database.
    """
    polled(pycolmap, lambda token: pycolmap.extract_features(
        database, image_dir, image_names=list(names), camera_mode=pycolmap.CameraMode.SINGLE,
        reader_options=reader, extraction_options=extraction, device=pycolmap.Device.cpu,
        cancellation_token=token), Path(database), "keypoints", len(names), tick, base)


def _match_pairs(pycolmap, database: Path, work_dir: Path, names: list[str], pairs: list[tuple[int, int]],
                 options, verification, progress) -> None:
    """Match and verify the given pairs (indices into ``names``) in one call, the bar
    following the pairs COLMAP has written."""
    pairs_file = work_dir / "pairs.txt"
    pairs_file.write_text("".join(f"{names[i]} {names[j]}\n" for i, j in pairs))
    pairing = pycolmap.ImportedPairingOptions()
    pairing.match_list_path = pairs_file
    with progress.stage("SfM matching", total=len(pairs), unit="pair") as tick:
        polled(pycolmap, lambda token: pycolmap.match_image_pairs(
            database, matching_options=options, pairing_options=pairing, verification_options=verification,
            device=pycolmap.Device.cpu, cancellation_token=token), database, "two_view_geometries", len(pairs), tick)
