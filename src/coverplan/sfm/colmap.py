"""Structure-from-Motion on simulated photos with pycolmap (CPU), and its alignment.

Known intrinsics (one PINHOLE camera, never refined), SIFT features at COLMAP's defaults,
exhaustive matching for small flights or each photo's co-visible partners for large ones,
incremental mapping. The largest model is aligned to the true camera centres by a similarity
(robust LO-RANSAC).
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from coverplan.errors import ParameterError

INSTALL_HINT = "simulate needs pycolmap; install it with: pip install 'coverplan[sfm]'"


def require_pycolmap():
    """The pycolmap module, or a one-line error saying how to get it."""
    try:
        import pycolmap
    except ImportError:
        raise ParameterError(INSTALL_HINT) from None
    return pycolmap


@dataclass
class SfmModel:
    """One SfM model, aligned to the scene's local frame (when it could be)."""

    image_names: list[str]  # registered photos
    points: np.ndarray  # (n, 3) 3D points in the local frame
    centres: np.ndarray  # (len(image_names), 3) camera centres in the local frame
    reprojection_error_px: float
    mean_track_length: float
    aligned: bool


@dataclass
class SfmResult:
    models: list[SfmModel]  # largest first
    verified_pairs: int
    matched_pairs: int
    seconds: dict = field(default_factory=dict)

    @property
    def largest(self) -> SfmModel | None:
        return self.models[0] if self.models else None


def covisible_pairs(seen: list[np.ndarray], cell: float, k: int) -> list[tuple[int, int]]:
    """Pairs of photos worth matching in a large flight: for each photo, the ``k`` photos that
    see most of the same scene (points its pixels hit, counted in cells of ``cell`` metres).

    Nearest camera positions are not enough: a flight round a tall block has photos a few
    metres apart looking at different walls, and photos of one wall from far apart."""
    import scipy.sparse as sp

    rows, cols = [], []
    keys: dict = {}
    for i, pts in enumerate(seen):
        if len(pts) == 0:
            continue
        cells = np.unique(np.floor(pts / cell).astype(np.int64), axis=0)
        ids = np.array([keys.setdefault(tuple(v), len(keys)) for v in cells])
        rows.append(np.full(len(ids), i))
        cols.append(ids)
    n = len(seen)
    if not rows:
        return []
    m = sp.csr_matrix((np.ones(sum(map(len, rows))), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n, len(keys)))
    shared = (m @ m.T).toarray()
    np.fill_diagonal(shared, 0)
    pairs = set()
    for i in range(n):
        best = np.argsort(-shared[i])[:k]
        for j in best[shared[i, best] > 0]:
            pairs.add((min(i, int(j)), max(i, int(j))))
    return sorted(pairs)


MATCHINGS = ("spatial", "covisible")
SPATIAL_NEIGHBOURS = 50


def check_matching(kind: str) -> str:
    """``kind`` if it names a way of pairing photos for large flights, else a one-line error."""
    if kind not in MATCHINGS:
        raise ParameterError(f"unknown matching {kind!r}; choose one of {', '.join(MATCHINGS)}")
    return kind


def write_position_priors(pycolmap, database: Path, names: list[str], positions: np.ndarray, sigma_m: float) -> None:
    """Each photo's recorded position (its GNSS tag, local metres) as a COLMAP pose prior."""
    db = pycolmap.Database.open(database) if hasattr(pycolmap.Database, "open") else pycolmap.Database(database)
    try:
        index = {name: k for k, name in enumerate(names)}
        cov = np.eye(3) * float(sigma_m) ** 2
        for image in db.read_all_images():
            k = index.get(image.name)
            if k is None:
                continue
            prior = pycolmap.PosePrior(position=np.asarray(positions[k], dtype=float), position_covariance=cov,
                                       coordinate_system=pycolmap.PosePriorCoordinateSystem.CARTESIAN)
            prior.corr_data_id = image.data_id
            db.write_pose_prior(prior)
    finally:
        db.close()


def run_sfm(image_dir: Path, names: list[str], photo, true_centres: np.ndarray, pairs: list[tuple[int, int]],
            work_dir: Path, *, exhaustive_limit: int = 80, max_features: int = 8192, threads: int = -1,
            seed: int = 0, progress=None, matching: str = "covisible", recorded_positions: np.ndarray | None = None,
            neighbour_distance: float = 100.0, neighbours: int = SPATIAL_NEIGHBOURS) -> SfmResult:
    """Features, matching and incremental mapping over the photos ``names`` in ``image_dir``.

    Up to ``exhaustive_limit`` photos every pair is matched. Above it, ``matching`` "spatial"
    matches each photo with its ``neighbours`` nearest by ``recorded_positions`` (the GNSS
    tags, as a user's own COLMAP run would), within ``neighbour_distance`` metres; "covisible"
    matches the given ``pairs`` (indices into ``names``)."""
    import time

    pycolmap = require_pycolmap()
    check_matching(matching)
    pycolmap.logging.minloglevel = 2  # COLMAP's per-image log drowns the progress bars
    work_dir = Path(work_dir)
    if work_dir.exists():
        shutil.rmtree(work_dir)
    work_dir.mkdir(parents=True)
    database = work_dir / "database.db"
    seconds = {}

    t = time.perf_counter()
    reader = pycolmap.ImageReaderOptions()
    reader.camera_model = "PINHOLE"
    reader.camera_params = f"{photo.fx},{photo.fy},{photo.cx},{photo.cy}"
    extraction = pycolmap.FeatureExtractionOptions()
    extraction.num_threads = threads
    extraction.max_image_size = max(photo.width, photo.height)
    extraction.sift.max_num_features = max_features
    # The rest of SIFT stays at COLMAP's defaults, as a user's own COLMAP run would have it.
    # Starting at octave 0 instead of -1 (no upsampling) found a quarter of the features and
    # left about 10 % of a well-photographed wall without a point within 0.2 m.
    with _stage(progress, "SfM features"):
        pycolmap.extract_features(database, image_dir, image_names=names, camera_mode=pycolmap.CameraMode.SINGLE,
                                  reader_options=reader, extraction_options=extraction,
                                  device=pycolmap.Device.cpu)
    seconds["features"] = time.perf_counter() - t

    t = time.perf_counter()
    matching_kind = matching
    matching = pycolmap.FeatureMatchingOptions()
    matching.num_threads = threads
    with _stage(progress, "SfM matching"):
        if len(names) <= exhaustive_limit:
            pycolmap.match_exhaustive(database, matching_options=matching, device=pycolmap.Device.cpu)
        elif matching_kind == "spatial":
            write_position_priors(pycolmap, database, names, recorded_positions if recorded_positions is not None
                                  else true_centres, 1.0)
            pairing = pycolmap.SpatialPairingOptions()
            pairing.ignore_z = False
            pairing.max_num_neighbors = int(neighbours)
            pairing.max_distance = float(neighbour_distance)
            pycolmap.match_spatial(database, matching_options=matching, pairing_options=pairing,
                                   device=pycolmap.Device.cpu)
        else:
            pairs_file = work_dir / "pairs.txt"
            pairs_file.write_text("".join(f"{names[i]} {names[j]}\n" for i, j in pairs))
            pairing = pycolmap.ImportedPairingOptions()
            pairing.match_list_path = pairs_file
            pycolmap.match_image_pairs(database, matching_options=matching, pairing_options=pairing,
                                       device=pycolmap.Device.cpu)
    seconds["matching"] = time.perf_counter() - t
    db = pycolmap.Database.open(database) if hasattr(pycolmap.Database, "open") else pycolmap.Database(database)
    matched, verified = int(db.num_matched_image_pairs()), int(db.num_verified_image_pairs())
    db.close()

    t = time.perf_counter()
    options = pycolmap.IncrementalPipelineOptions()
    options.ba_refine_focal_length = False
    options.ba_refine_principal_point = False
    options.ba_refine_extra_params = False
    options.num_threads = threads
    options.random_seed = seed
    options.multiple_models = True
    options.min_model_size = 3
    sparse = work_dir / "sparse"
    sparse.mkdir()
    with _stage(progress, "SfM mapping", total=len(names)) as tick:
        recs = pycolmap.incremental_mapping(database, image_dir, sparse, options=options,
                                            next_image_callback=lambda: tick(1))
    seconds["mapping"] = time.perf_counter() - t
    for k, rec in enumerate(sorted(recs.values(), key=lambda r: -r.num_reg_images())):
        (sparse / str(k)).mkdir(exist_ok=True)
        rec.write(sparse / str(k))  # COLMAP's own files, for its GUI and for independent checks

    index = {name: i for i, name in enumerate(names)}
    models = [_aligned(pycolmap, rec, index, true_centres) for rec in recs.values()]
    models.sort(key=lambda m: -len(m.image_names))
    return SfmResult(models, verified, matched, seconds)


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
    if sim is None:
        return SfmModel(names, points, centres, error, track, aligned=False)
    m = np.asarray(sim.matrix())
    return SfmModel(names, points @ m[:, :3].T + m[:, 3], centres @ m[:, :3].T + m[:, 3], error, track, aligned=True)


class _stage:
    """A progress stage if a Progress was given, else nothing."""

    def __init__(self, progress, name, total=None):
        self.cm = progress.stage(name, total=total, unit="img") if progress is not None else None

    def __enter__(self):
        return self.cm.__enter__() if self.cm is not None else (lambda _n=1: None)

    def __exit__(self, *exc):
        return self.cm.__exit__(*exc) if self.cm is not None else False
