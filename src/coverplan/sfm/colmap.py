"""Structure-from-Motion on simulated photos with pycolmap (CPU), and its alignment.

One COLMAP camera per camera of the photos (sfm/cameras.py: known and fixed for rendered
photos, refined in bundle adjustment for real ones), SIFT features at COLMAP's defaults,
exhaustive matching for small flights; for large ones, the pairs COLMAP's spatial matcher
takes from the photos' GNSS tags (or each photo's co-visible partners); COLMAP's incremental
or global mapper. The largest model is aligned to the true camera centres by a similarity
(robust LO-RANSAC).
"""

from __future__ import annotations

import shutil
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from coverplan.errors import ParameterError, SfmError
from coverplan.progress import Progress
from coverplan.sfm.cameras import CameraGroup
from coverplan.sfm.database import (
    _clear_matches,
    _match_pairs,
    extract_features,
    open_database,
    polled,
    write_position_priors,
)
from coverplan.sfm.mapping import map_models, pick_mapper
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
    progress = progress or Progress()
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
                progress.stage("SfM features", total=len(names), unit="img") as tick:
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
                progress.stage("SfM matching", total=total, unit="pair") as tick:
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
    progress.note(f"{stage}: kept from the earlier run in {database}")


@contextmanager
def _colmap_failure(stage: str, database: Path):
    """COLMAP's own errors as one line naming the stage that failed and the database kept."""
    try:
        yield
    except RuntimeError as exc:
        what = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
        raise SfmError(f"COLMAP failed in {stage} ({what}); what it had done is kept in {database}") from None


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
