"""Structure-from-Motion on simulated photos with pycolmap (CPU), and its alignment.

One COLMAP camera per camera of the photos (sfm/cameras.py: known and fixed for rendered
photos, refined in bundle adjustment for real ones), SIFT features at COLMAP's defaults,
exhaustive matching for small flights; for large ones, the pairs COLMAP's spatial matcher
takes from the photos' GNSS tags (or each photo's co-visible partners); COLMAP's incremental
or global mapper. The largest model is aligned to the true camera centres by a similarity
(robust LO-RANSAC).
"""

from __future__ import annotations

import os
import shutil
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from coverplan.errors import ParameterError, SfmError
from coverplan.progress import clock_bar
from coverplan.sfm.cameras import CameraGroup
from coverplan.sfm.pairs import spatial_pairs
from coverplan.sfm.resume import WorkFolder, photo_stamps, stage_key

INSTALL_HINT = "{command} needs pycolmap; install it with: pip install 'coverplan[sfm]'"


def require_pycolmap(command: str = "simulate"):
    """The pycolmap module, or a one-line error saying how to get it for ``command``.

    Parameters
    ----------
    command : str
        The subcommand that needs it.

    Returns
    -------
    module
        pycolmap.

    Raises
    ------
    ParameterError
        When pycolmap is not installed.
    """
    try:
        import pycolmap
    except ImportError:
        raise ParameterError(INSTALL_HINT.format(command=f"coverplan {command}")) from None
    return pycolmap


@dataclass
class SfmModel:
    """One SfM model, aligned to the scene's local frame (when it could be).

    Parameters
    ----------
    image_names : list of str
        Registered photos.
    points : (n, 3) float
        3D points in the local frame.
    centres : (k, 3) float
        Camera centres in the local frame.
    reprojection_error_px : float
        Mean reprojection error.
    mean_track_length : float
        Photos per 3D point.
    aligned : bool
        Whether the model is in the local frame.
    rotations : (k, 3, 3) float, optional
        Each photo's camera-from-local rotation.
    intrinsics : (k, 6) float, optional
        fx, fy, cx, cy, width and height, px.
    """

    image_names: list[str]  # registered photos
    points: np.ndarray  # (n, 3) 3D points in the local frame
    centres: np.ndarray  # (len(image_names), 3) camera centres in the local frame
    reprojection_error_px: float
    mean_track_length: float
    aligned: bool
    rotations: np.ndarray | None = None  # (k, 3, 3) each photo's camera-from-local rotation
    intrinsics: np.ndarray | None = None  # (k, 6) fx, fy, cx, cy, width, height in px (pinhole part)

    def centre_error_m(self, names: list[str], true_centres: np.ndarray) -> dict:
        """Median and max distance (m) from each registered camera to where its photo was taken
        (``true_centres``, in the order of ``names``); NaN when the model is not aligned.

        Parameters
        ----------
        names : list of str
            Photo names.
        true_centres : (n, 3) float
            Where they were taken.

        Returns
        -------
        dict
            ``median`` and ``max``, metres.
        """
        if not self.aligned or not self.image_names:
            return {"median": float("nan"), "max": float("nan")}
        index = {name: k for k, name in enumerate(names)}
        err = np.linalg.norm(self.centres - true_centres[[index[n] for n in self.image_names]], axis=1)
        return {"median": float(np.median(err)), "max": float(err.max())}


@dataclass
class SfmResult:
    """What COLMAP made of a set of photos: its models, largest first, and the work it took.

    Parameters
    ----------
    models : list of SfmModel
        Largest first.
    verified_pairs : int
        Pairs with a verified two-view geometry.
    matched_pairs : int
        Pairs matched.
    seconds : dict
        Seconds per stage.
    mapper : str
        The COLMAP mapper that made the models.
    """
    models: list[SfmModel]  # largest first
    verified_pairs: int
    matched_pairs: int
    seconds: dict = field(default_factory=dict)
    mapper: str = "incremental"  # the COLMAP mapper that made the models

    @property
    def largest(self) -> SfmModel | None:
        """The largest model, or None."""
        return self.models[0] if self.models else None


MATCHINGS = ("spatial", "covisible")
SPATIAL_NEIGHBOURS = 50
MAX_FEATURES = 8192  # SIFT features per photo: COLMAP's own default


def check_matching(kind: str) -> str:
    """``kind`` if it names a way of pairing photos for large flights, else a one-line error.

    Parameters
    ----------
    kind : str
        ``covisible`` or ``spatial``.

    Returns
    -------
    str
        ``kind``.

    Raises
    ------
    ParameterError
        For another name.
    """
    if kind not in MATCHINGS:
        raise ParameterError(f"unknown matching {kind!r}; choose one of {', '.join(MATCHINGS)}")
    return kind


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
    if mapper == "incremental":
        with _stage(progress, "SfM mapping", total=photos) as tick:
            return _map(pycolmap, mapper, database, image_dir, sparse, threads, seed, tick, refine=refine)
    estimate = global_mapping_seconds(photos, threads)
    with _stage(progress, "SfM mapping (time estimated)", total=estimate, unit="s") as tick, \
            clock_bar(tick, estimate):
        return _map(pycolmap, mapper, database, image_dir, sparse, threads, seed, tick, refine=refine)


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


def run_sfm(image_dir: Path, names: list[str], photo, true_centres: np.ndarray, pairs: list[tuple[int, int]],
            work_dir: Path, *, exhaustive_limit: int = 80, max_features: int = MAX_FEATURES, threads: int = -1,
            seed: int = 0, progress=None, matching: str = "covisible", recorded_positions: np.ndarray | None = None,
            neighbour_distance: float = 100.0, neighbours: int = SPATIAL_NEIGHBOURS,
            mapper: str = "auto", working_px: int | None = None, cameras: list | None = None,
            resume: bool = False) -> SfmResult:
    """Features, matching and mapping over the photos ``names`` in ``image_dir``.

    Up to ``exhaustive_limit`` photos every pair is matched. Above it, ``matching`` "spatial"
    matches the pairs COLMAP's spatial matcher takes (``spatial_pairs``: each photo's
    ``neighbours`` nearest by ``recorded_positions``, the GNSS tags, within
    ``neighbour_distance`` metres, as a user's own COLMAP run would); "covisible" matches the
    given ``pairs`` (indices into ``names``). Features and matches are one pycolmap call
    each, their bars following the rows COLMAP writes. ``mapper``: COLMAP's incremental
    mapper, its global one (GLOMAP: rotation averaging, then all positions at once), or
    "auto" (``pick_mapper``). ``working_px``: features are found on the photos scaled down to
    this longest side (None: full size); COLMAP scales the keypoints back. ``cameras``: the
    photos' CameraGroups (sfm/cameras.py; default: all taken with ``photo``, known exactly);
    intrinsics are refined when a group asks for it. ``resume``: keep the features and matches
    an earlier run left in ``work_dir`` for the same photos and options (sfm/resume.py);
    otherwise the folder is emptied first.

    Parameters
    ----------
    image_dir : Path
        The photos.
    names : list of str
        Photo names.
    photo : PhotoCamera
        The camera of every photo, unless ``cameras`` is given.
    true_centres : (n, 3) float
        Where the photos were taken, for alignment.
    pairs : list of (int, int)
        Pairs to match under ``covisible`` matching.
    work_dir : Path
        COLMAP's database and models.
    exhaustive_limit : int
        Photos up to which every pair is matched.
    max_features : int
        SIFT features per photo.
    threads : int
        Threads (-1: every core).
    seed : int
        COLMAP's seed.
    progress : Progress, optional
        Draws the bars.
    matching : {"covisible", "spatial"}
        How pairs are chosen above ``exhaustive_limit``.
    recorded_positions : (n, 3) float, optional
        GNSS tags, for spatial matching and position priors.
    neighbour_distance : float
        Metres.
    neighbours : int
        Spatial neighbours per photo.
    mapper : {"auto", "incremental", "global"}
        The COLMAP mapper.
    working_px : int, optional
        The photos' width as COLMAP reads them.
    cameras : list of CameraGroup, optional
        The photos' cameras.
    resume : bool
        Keep the stages a previous run finished with the same inputs.

    Returns
    -------
    SfmResult
        The models.
    """
    import time

    pycolmap = require_pycolmap()
    check_matching(matching)
    mapper = pick_mapper(mapper, len(names))
    pycolmap.logging.minloglevel = 2  # COLMAP's per-image log drowns the progress bars
    work_dir = Path(work_dir)
    cameras = cameras or [CameraGroup.known(photo, names)]
    longest = max(max(g.photo.width, g.photo.height) for g in cameras)
    working = longest if working_px is None else min(longest, int(working_px))
    exhaustive = len(names) <= exhaustive_limit
    recorded = recorded_positions if recorded_positions is not None else true_centres
    features_key = stage_key("features", photo_stamps(image_dir, names), working, max_features,
                             [(g.model, g.colmap_params, list(g.names)) for g in cameras])
    matching_key = stage_key("matching", features_key, exhaustive, matching, neighbours, neighbour_distance, seed,
                             np.asarray(recorded, dtype=float) if matching == "spatial" else list(map(list, pairs)))
    folder = WorkFolder(work_dir, {"features": features_key, "matching": matching_key}, resume)
    database = work_dir / "database.db"
    seconds = {}

    t = time.perf_counter()
    extraction = pycolmap.FeatureExtractionOptions()
    extraction.num_threads = threads
    extraction.max_image_size = working
    extraction.sift.max_num_features = max_features
    # The rest of SIFT stays at COLMAP's defaults, as a user's own COLMAP run would have it.
    # Starting at octave 0 instead of -1 (no upsampling) found a quarter of the features and
    # left about 10 % of a well-photographed wall without a point within 0.2 m.
    if folder.has("features"):
        _kept(progress, "SfM features", database)
    else:
        with _colmap_failure("feature extraction", database), \
                _stage(progress, "SfM features", total=len(names)) as tick:
            done = 0
            for group in cameras:  # one call per camera: each call makes its camera from its options
                reader = pycolmap.ImageReaderOptions()
                reader.camera_model, reader.camera_params = group.model, group.colmap_params
                extract_features(pycolmap, database, image_dir, group.names, reader, extraction, tick, base=done)
                done += len(group.names)
        folder.finished("features")
    seconds["features"] = time.perf_counter() - t

    t = time.perf_counter()
    matching_kind = matching
    matching = pycolmap.FeatureMatchingOptions()
    matching.num_threads = threads
    # COLMAP seeds its verification RANSAC from the clock unless told: with the draw's seed a
    # draw verifies the same inliers, pair for pair, on every run.
    verification = pycolmap.TwoViewGeometryOptions()
    verification.ransac.random_seed = int(seed)
    if folder.has("features") and not folder.has("matching"):
        _clear_matches(pycolmap, database)
    if folder.has("matching"):
        _kept(progress, "SfM matching", database)
    elif exhaustive:
        total = len(names) * (len(names) - 1) // 2
        with _colmap_failure("exhaustive matching", database), \
                _stage(progress, "SfM matching", total=total, unit="pair") as tick:
            polled(pycolmap, lambda token: pycolmap.match_exhaustive(
                database, matching_options=matching, verification_options=verification,
                device=pycolmap.Device.cpu, cancellation_token=token), database, "two_view_geometries", total, tick)
    else:
        if matching_kind == "spatial":
            with _colmap_failure("writing the GNSS positions as pose priors", database):
                write_position_priors(pycolmap, database, names, recorded, 1.0)
            pairs = spatial_pairs(recorded, neighbours, neighbour_distance)
        with _colmap_failure("matching", database):
            _match_pairs(pycolmap, database, work_dir, names, pairs, matching, verification, progress)
    folder.finished("matching")
    seconds["matching"] = time.perf_counter() - t
    db = open_database(pycolmap, database)
    matched, verified = int(db.num_matched_image_pairs()), int(db.num_verified_image_pairs())
    db.close()

    t = time.perf_counter()
    sparse = work_dir / "sparse"
    if sparse.exists():
        shutil.rmtree(sparse)
    sparse.mkdir()
    with _colmap_failure(f"{mapper} mapping", database):
        recs = map_models(pycolmap, mapper, database, image_dir, sparse, threads, seed, len(names), progress,
                          refine=any(g.refine for g in cameras))
    seconds["mapping"] = time.perf_counter() - t
    for k, rec in enumerate(sorted(recs.values(), key=lambda r: -r.num_reg_images())):
        (sparse / str(k)).mkdir(exist_ok=True)
        rec.write(sparse / str(k))  # COLMAP's own files, for its GUI and for independent checks

    return SfmResult(aligned_models(pycolmap, recs, names, true_centres), verified, matched, seconds, mapper)


def aligned_models(pycolmap, recs: dict, names: list[str], true_centres: np.ndarray) -> list[SfmModel]:
    """COLMAP's models (``recs``, as its mappers return them), each aligned to the true camera
    centres (``true_centres``, in the order of the photo ``names``), the largest first.

    Parameters
    ----------
    pycolmap : module
        pycolmap.
    recs : dict
        COLMAP's reconstructions.
    names : list of str
        Photo names.
    true_centres : (n, 3) float
        Camera centres, local frame.

    Returns
    -------
    list of SfmModel
        Largest first.
    """
    index = {name: i for i, name in enumerate(names)}
    models = [_aligned(pycolmap, rec, index, true_centres) for rec in recs.values()]
    models.sort(key=lambda m: -len(m.image_names))
    return models


def _kept(progress, stage: str, database: Path) -> None:
    if progress is not None:
        progress.note(f"{stage}: kept from the earlier run in {database}")


def _clear_matches(pycolmap, database: Path) -> None:
    """Drop the matches a run stopped during matching left half written."""
    db = open_database(pycolmap, database)
    try:
        db.clear_matches()
        db.clear_two_view_geometries()
    finally:
        db.close()


@contextmanager
def _colmap_failure(stage: str, database: Path):
    """COLMAP's own errors as one line naming the stage that failed and the database kept."""
    try:
        yield
    except RuntimeError as exc:
        what = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
        raise SfmError(f"COLMAP failed in {stage} ({what}); what it had done is kept in {database}") from None


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
    with _stage(progress, "SfM matching", total=len(pairs), unit="pair") as tick:
        polled(pycolmap, lambda token: pycolmap.match_image_pairs(
            database, matching_options=options, pairing_options=pairing, verification_options=verification,
            device=pycolmap.Device.cpu, cancellation_token=token), database, "two_view_geometries", len(pairs), tick)


def _aligned(pycolmap, rec, index: dict, true_centres: np.ndarray) -> SfmModel:
    images = [rec.images[i] for i in rec.reg_image_ids()]
    names = [im.name for im in images]
    centres = np.array([im.projection_center() for im in images]).reshape(-1, 3)
    points = np.array([p.xyz for p in rec.points3D.values()]).reshape(-1, 3)
    error = float(rec.compute_mean_reprojection_error()) if rec.num_points3D() else float("nan")
    track = float(rec.compute_mean_track_length()) if rec.num_points3D() else 0.0
    target = true_centres[[index[n] for n in names]] if names else np.zeros((0, 3))
    sim = None
    if len(names) >= 3:
        ransac = pycolmap.RANSACOptions()
        ransac.max_error = max(0.05, 0.002 * float(np.ptp(target, axis=0).max()))
        sim = pycolmap.estimate_sim3d_robust(centres, target, ransac)
        sim = sim["tgt_from_src"] if isinstance(sim, dict) else sim
    rot = np.array([np.asarray(im.cam_from_world().rotation.matrix()) for im in images]).reshape(-1, 3, 3)
    cams = [rec.cameras[im.camera_id] for im in images]
    intr = np.array([[c.focal_length_x, c.focal_length_y, c.principal_point_x, c.principal_point_y, c.width,
                      c.height] for c in cams]).reshape(-1, 6)
    if sim is None:
        return SfmModel(names, points, centres, error, track, aligned=False, rotations=rot, intrinsics=intr)
    m = np.asarray(sim.matrix())
    turn = m[:, :3] / np.cbrt(np.linalg.det(m[:, :3]))  # the similarity's rotation: camera-from-local = R R_s^T
    return SfmModel(names, points @ m[:, :3].T + m[:, 3], centres @ m[:, :3].T + m[:, 3], error, track,
                    aligned=True, rotations=rot @ turn.T, intrinsics=intr)


class _stage:
    """A progress stage if a Progress was given, else nothing."""

    def __init__(self, progress, name, total=None, unit="img"):
        self.cm = progress.stage(name, total=total, unit=unit) if progress is not None else None

    def __enter__(self):
        return self.cm.__enter__() if self.cm is not None else (lambda _n=1: None)

    def __exit__(self, *exc):
        return self.cm.__exit__(*exc) if self.cm is not None else False
