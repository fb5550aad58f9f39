"""check(): did the photos of a real flight get everything? SfM on them, judged on the model.

The photos' metadata (sfm/photos.py) gives their positions and the camera; photos without a
position are named and left out. COLMAP runs on the rest as in ``simulate`` (every pair up to
80 photos, else its spatial matcher on the GNSS tags), each model is aligned to the scene
through the photos' GNSS positions, and the largest is then fitted to the scene's surfaces
(a rigid ICP on its 3D points): a flight-wide GNSS bias of a metre or two would otherwise
decide what counts as rebuilt at 0.1-0.2 m. The verdict is ``simulate``'s: photos registered,
models, and the share of the surface rebuilt per class, with where it is missing.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from coverplan.files import json_text
from coverplan.geometry import geo
from coverplan.progress import Progress
from coverplan.sfm.cameras import LENS_MODEL
from coverplan.sfm.colmap import SPATIAL_NEIGHBOURS, require_pycolmap, run_sfm
from coverplan.sfm.judge import judge_samples, reconstructed_surface
from coverplan.sfm.lost import lost_photos
from coverplan.sfm.photo_cover import photo_cover, point_ceiling
from coverplan.sfm.photo_route import photos_route
from coverplan.sfm.render import ground_plane
from coverplan.sfm.simulate import JUDGE_SPACING_M
from coverplan.sfm.simulation import CLASS_MIN, REGISTERED_MIN, SURFACE_MIN, Simulation

ICP_ROUNDS = 15
ICP_SAMPLE = 20_000
LOST_SHOWN = 5  # photos outside the model named in the table
WORKING_PX = 2000  # longest side of the photos as their features are found (benchmarks/README.md, check)
MAX_FIT_M = 3.0  # a GNSS drone's flight-wide horizontal error stays within this; the fit moves no farther
# Heights are a GNSS drone's weakest figure (several metres, and barometric drift over a flight):
# the fit may move the model this far up or down.
MAX_FIT_VERTICAL_M = 10.0
JUDGING_RADIUS_M = 0.2  # a surface point counts as rebuilt with a 3D point this near


@dataclass
class Check:
    """What SfM made of a flight's real photos, and which photos it could not use.

    Parameters
    ----------
    simulation : Simulation
        The verdict, in simulate's terms.
    route : Route
        The photos as a route in the scene's frame (positions from their GNSS tags).
    names : list of str
        The photos used, in route order.
    left_out : list of (str, str)
        Name and why of the photos without a position.
    icp_shift_m : float
        How far the fit to the scene moves the model from its GNSS alignment.
    fitted : bool
        Whether the fit was applied.
    missing : dict
        Per surface class: square metres not rebuilt at 0.2 m.
    gnss_residual_m : dict
        Median and max distance of a camera centre from its GNSS tag, aligned.
    unjudged : str
        Why the surface could not be judged; empty when it was.
    photo_cover : dict
        Where the sparse model is too thin: what the photos see.
    point_ceiling_pct : float
        The most surface the sparse points could reach at 0.2 m.
    cameras : list of dict
        Each camera COLMAP was given: what it is, how many photos.
    lost : list of (str, str)
        Name and why of the photos outside the largest model.
    """

    simulation: Simulation  # the verdict, in simulate's terms
    route: object  # the photos as a Route in the scene's frame (positions from their GNSS tags)
    names: list  # the photos used, in route order
    left_out: list = field(default_factory=list)  # (name, why) of the photos without a position
    icp_shift_m: float = 0.0  # how far the fit to the scene moves the model from its GNSS alignment
    fitted: bool = False  # whether the fit was applied (not when it would move the model > MAX_FIT_M)
    missing: dict = field(default_factory=dict)  # per class: m2 not rebuilt at 0.2 m
    gnss_residual_m: dict = field(default_factory=dict)  # median / max camera centre to its GNSS tag, aligned
    unjudged: str = ""  # why the surface could not be judged; "" when it was
    photo_cover: dict = field(default_factory=dict)  # where the sparse model is too thin: what the photos see
    point_ceiling_pct: float = 100.0  # the most surface the sparse points could reach at 0.2 m
    cameras: list = field(default_factory=list)  # each camera COLMAP was given: what it is, how many photos
    lost: list = field(default_factory=list)  # (name, why) of the photos outside the largest model

    @property
    def thin(self) -> bool:
        """The sparse model has too few points to meet the surface bar at 0.2 m, however good."""
        return bool(self.photo_cover)

    @property
    def reconstructable(self) -> bool:
        """The verdict: simulate's bar, on the photos' 2-view cover where the sparse model is thin."""
        sim = self.simulation
        if self.unjudged:
            return False
        if not self.thin:
            return sim.reconstructable
        return (sim.registered >= REGISTERED_MIN * sim.photos and self.photo_cover["pct"] >= SURFACE_MIN
                and all(v >= CLASS_MIN for v in self.photo_cover["by_class_pct"].values()))

    def table(self) -> str:
        rows = self.rows()
        w = max(len(r[0]) for r in rows)
        return "\n".join(f"{k:<{w}}  {v}" for k, v in rows)

    def rows(self) -> list[tuple[str, str]]:
        """The table's (label, value) rows; a label indented by two spaces details the row above."""
        rows = [("photos in the folder", f"{len(self.names) + len(self.left_out)}"),
                ("left out", ", ".join(n for n, _ in self.left_out[:8])
                 + (f" and {len(self.left_out) - 8} more" if len(self.left_out) > 8 else "") or "none"),
                ("heights", self.route.extra.get("heights", "") or "-"),
                ("camera" if len(self.cameras) < 2 else "cameras", "; ".join(self.cameras) or "-"),
                ("aligned to the scene", self._alignment())]
        if self.lost:
            more = f", the first {LOST_SHOWN} here (all in check.json)" if len(self.lost) > LOST_SHOWN else ""
            rows.append(("not in the model", f"{len(self.lost)} photos{more}"))
            rows += [(f"  {n}", w) for n, w in self.lost[:LOST_SHOWN]]
        if self.gnss_residual_m:
            residual = self.gnss_residual_m
            rows.append(("camera centres from their tags",
                         f"median {residual['median']:.2f} m, max {residual['max']:.2f} m (after alignment)"))
        verdict = self.simulation.rows()[1:]
        if self.unjudged:
            rows += [r for r in verdict if not r[0].startswith(("surface", "  ", "reconstructable"))]
            rows.append(("surface", f"not judged: {self.unjudged}"))
        elif self.thin:
            rows += [r for r in verdict if r[0] != "reconstructable"]
            cover = self.photo_cover
            rows.append(("sparse points", f"too thin to judge at 0.2 m: {self.simulation.points:,} points could "
                                          f"reach at most {self.point_ceiling_pct:.1f} % of the surface"))
            rows.append(("seen by 2+ registered photos", f"{cover['pct']:.1f} % (what a dense reconstruction "
                                                         "of these photos can rebuild at most)"))
            rows += [(f"  {c}", f"{v:.1f} %") for c, v in cover["by_class_pct"].items()]
            rows.append(("reconstructable", ("yes" if self.reconstructable else "no")
                         + ", judged by what the registered photos see (>= 98 % registered, >= 95 % of the "
                           "surface and >= 90 % of every class seen twice)"))
            worst = sorted(self.missing.items(), key=lambda kv: -kv[1])[:4]
            rows += [("missing", ", ".join(f"{c} {a:.1f} m2" for c, a in worst if a > 0.05) or "nothing")]
        else:
            rows += verdict
            worst = sorted(self.missing.items(), key=lambda kv: -kv[1])[:4]
            rows += [("missing", ", ".join(f"{c} {a:.1f} m2" for c, a in worst if a > 0.05) or "nothing")]
        return rows

    def _alignment(self) -> str:
        if self.fitted and not self.unjudged:
            return f"through the GNSS tags, then fitted to the surfaces (moved {self.icp_shift_m:.2f} m)"
        if self.fitted:
            return "through the GNSS tags; no fit brought the model onto the surfaces"
        return f"through the GNSS tags only (a fit would move it {self.icp_shift_m:.1f} m)" if self.icp_shift_m \
            else "through the GNSS tags only"

    def to_dict(self) -> dict:
        verdict = self.simulation.to_dict()
        verdict.pop("centre_error_m")  # real photos have no true centres: gnss_residual_m is what is known
        return {"photos_used": self.names, "cameras": self.cameras, "left_out": [{"photo": n, "why": w} for n, w in self.left_out],
                "not_registered": [{"photo": n, "why": w} for n, w in self.lost],
                "icp_shift_m": self.icp_shift_m, "fitted": self.fitted, "missing_m2": self.missing,
                "gnss_residual_m": self.gnss_residual_m, "judged": not self.unjudged,
                "why_not_judged": self.unjudged or None, **verdict,
                "judged_by": "" if self.unjudged else "photo views" if self.thin else "sparse points",
                "point_ceiling_pct": self.point_ceiling_pct,
                "photo_cover_pct": self.photo_cover.get("pct"),
                "photo_cover_by_class_pct": self.photo_cover.get("by_class_pct"),
                "reconstructable": self.reconstructable}


def _median_distance(points: np.ndarray, surfaces: trimesh.Trimesh, sample: int = 5000) -> float:
    """Median distance, m, from (a sample of) the model's points to the scene's surfaces."""
    rng = np.random.default_rng(0)
    pts = points if len(points) <= sample else points[rng.choice(len(points), sample, replace=False)]
    return float(np.median(trimesh.proximity.ProximityQuery(surfaces).on_surface(pts)[1]))


def _why_unjudged(best, apart: float | None, fitted: bool, fit: bool) -> str:
    """Why the surface cannot be judged ("" when it can): no model, a model the GNSS tags could
    not place, or one that sits farther from the scene than the judging radius."""
    if best is None:
        return "COLMAP made no model of the photos"
    if not best.aligned:
        return "the model could not be placed through the photos' GNSS tags"
    if apart is not None and apart > 2.0 * JUDGING_RADIUS_M:
        how = ("a fit to the surfaces would move it beyond a GNSS error (see 'aligned to the scene'); check the "
               "georeference (--crs / --geo-origin) and the height datum") if fit and not fitted else \
            "judged without a fit (--no-fit)" if not fit else "the fit did not bring it onto the surfaces"
        return (f"the model's points lie a median {apart:.1f} m from the scene's surfaces, farther than the "
                f"{JUDGING_RADIUS_M:g} m a point may be from the surface it rebuilds: {how}")
    return ""


def fit_to_scene(points: np.ndarray, surfaces: trimesh.Trimesh, rounds: int = ICP_ROUNDS,
                 sample: int = ICP_SAMPLE, seed: int = 0, reach: float = MAX_FIT_VERTICAL_M) -> np.ndarray:
    """A rigid transform (4, 4) moving ``points`` (n, 3) onto ``surfaces``: ICP on a sample,
    each round on the pairs within three times the median distance (at least 0.3 m, at most
    ``reach``: farther points are clutter, not the same surface).

    Parameters
    ----------
    points : (n, 3) float
        The model's points.
    surfaces : trimesh.Trimesh
        The scene's surfaces.
    rounds : int
        ICP rounds.
    sample : int
        Points used.
    seed : int
        The sample's seed.
    reach : float
        Metres.

    Returns
    -------
    (4, 4) float
        The transform.
    """
    rng = np.random.default_rng(seed)
    pts = points if len(points) <= sample else points[rng.choice(len(points), sample, replace=False)]
    total = np.eye(4)
    if len(pts) < 10:
        return total
    query = trimesh.proximity.ProximityQuery(surfaces)
    for _ in range(rounds):
        moved = pts @ total[:3, :3].T + total[:3, 3]
        closest, distance, _ = query.on_surface(moved)
        near = distance <= min(max(0.3, 3.0 * float(np.median(distance))), reach)
        if near.sum() < 10:
            break
        step, _, _ = trimesh.registration.procrustes(moved[near], closest[near], reflection=False, scale=False)
        total = step @ total
        if np.linalg.norm(step[:3, 3]) < 1e-4 and np.allclose(step[:3, :3], np.eye(3), atol=1e-6):
            break
    return total


def check(photos_dir, scene, out_dir, *, gsd: float = 0.01, security: float = 3.0, threads: int = -1,
          exhaustive_limit: int = 80, spatial_neighbours: int = SPATIAL_NEIGHBOURS,
          judge_spacing: float = JUDGE_SPACING_M, fit: bool = True, mapper: str = "auto",
          working_px: int | None = WORKING_PX, lens_model: str = LENS_MODEL,
          progress: Progress | None = None) -> Check:
    """Reconstruct a flight's photos and judge what they rebuilt of ``scene``.

    Parameters
    ----------
    photos_dir : path
        JPEG/TIFF/PNG photos with EXIF GPS (and DJI XMP) tags.
    scene : Scene
        The models the photos should rebuild, georeferenced (CRS, city model or geodetic origin).
    out_dir : path
        COLMAP's files, ``check.json``, ``missing.ply`` and, with a georeference, ``missing.geojson``.
    gsd, security : float
        Only for the route the photos make (its report): the GSD and security distance to judge it by.
    fit : bool
        Fit the GNSS-aligned model to the scene's surfaces (ICP) before judging.
    mapper : {"auto", "incremental", "global"}
        COLMAP's mapper, as ``simulate`` takes it.
    working_px : int or None
        The longest side, px, the photos are scaled down to for their features (None: full size).
    lens_model : {"simple_radial", "radial", "opencv"}
        The distortion terms bundle adjustment estimates for a camera whose photos carry no
        DJI ``DewarpData`` (sfm/cameras.py ``LENS_MODELS``).
    threads : int
        Threads for COLMAP (-1: every core).
    exhaustive_limit : int
        Up to this many photos every pair is matched; above it, COLMAP's spatial matcher on
        the GNSS tags.
    spatial_neighbours : int
        Spatial matching's neighbours per photo.
    judge_spacing : float
        Spacing (m) of the samples the model is judged on.
    progress : Progress, optional
        Bars and stage timings.

    Returns
    -------
    Check
        Photos registered, models, the alignment and its residuals, the surface rebuilt per
        class, or why no verdict could be given.

    Raises
    ------
    InputFileError
        A folder without photos, or without two photos that carry a position.
    SfmError
        A COLMAP stage failed. The stages it finished stay in ``out_dir``/colmap, and a rerun
        on the same photos with the same options starts after them (a changed photo or
        option starts over).

    Examples
    --------
    >>> import coverplan  # doctest: +SKIP
    >>> scene = coverplan.load_scene("house.obj", geodetic_origin=(48.7758, 9.1829, 250.0))  # doctest: +SKIP
    >>> result = coverplan.check("photos/", scene, "check/")  # doctest: +SKIP
    >>> print(result.table())  # doctest: +SKIP
    """
    pycolmap = require_pycolmap("check")
    progress = progress or Progress()
    folder = Path(photos_dir)
    route, tags, left_out, cameras = photos_route(folder, scene, gsd, security, progress, least=2,
                                                   lens_model=lens_model)
    photo = cameras[0].photo
    names = [t.name for t in tags]
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    gnss = route.positions
    spread = float(np.ptp(gnss, axis=0).max()) if len(gnss) else 0.0
    sfm = run_sfm(folder, names, photo, gnss, [], out_dir / "colmap", exhaustive_limit=exhaustive_limit,
                  threads=threads, progress=progress, matching="spatial", recorded_positions=gnss,
                  neighbour_distance=max(0.5 * spread, 10.0), neighbours=spatial_neighbours, mapper=mapper,
                  working_px=working_px, cameras=cameras, resume=True)
    best = sfm.largest
    lost = lost_photos(pycolmap, out_dir / "colmap" / "database.db", sfm.models, names)
    pts = best.points if best is not None and best.aligned else np.zeros((0, 3))
    shift, fitted, apart, fit_matrix = 0.0, False, None, None
    if len(pts):
        surfaces = trimesh.util.concatenate([p.mesh for p in scene.parts] + [ground_plane(scene, 2.0 * route.d_opt)])
        if fit:
            with progress.stage("fitting the model to the scene"):
                m = fit_to_scene(pts, surfaces)
                centroid = pts.mean(axis=0)
                move = centroid @ m[:3, :3].T + m[:3, 3] - centroid
                shift = float(np.linalg.norm(move))
                fitted = float(np.linalg.norm(move[:2])) <= MAX_FIT_M and abs(float(move[2])) <= MAX_FIT_VERTICAL_M
                if fitted:
                    pts = pts @ m[:3, :3].T + m[:3, 3]
                    fit_matrix = m
                else:  # not a GNSS error: a wrong georeference or height datum, left for the user to see
                    progress.note(f"fitting the model to the scene would move it {shift:.1f} m "
                                  f"({float(np.linalg.norm(move[:2])):.1f} m across, {float(move[2]):+.1f} m up): "
                                  "kept at its GNSS alignment (check the georeference and heights)")
        apart = _median_distance(pts, surfaces)
    with progress.stage("judging the reconstruction"):
        samples = judge_samples(scene, judge_spacing)
        surface = reconstructed_surface(samples, pts)
    distance, classes = surface.pop("nearest_point_m"), surface.pop("classes")
    registered = set(best.image_names) if best is not None else set()
    sim = Simulation(photos=len(names), registered=len(registered),
                     registered_any=len(set().union(*[m.image_names for m in sfm.models])) if sfm.models else 0,
                     models=len(sfm.models), points=int(len(pts)),
                     reprojection_error_px=best.reprojection_error_px if best is not None else float("nan"),
                     centre_error_m={"median": float("nan"), "max": float("nan")}, surface=surface,
                     photo_width_px=photo.width, seconds=dict(sfm.seconds),
                     shot_registered=np.array([n in registered for n in names]), sample_points=samples.points,
                     sample_distance=distance, model_points=pts, conditions="photos", texture="real",
                     mapper=sfm.mapper)
    missing_mask = distance > JUDGING_RADIUS_M
    residual = best.centre_error_m(names, gnss) if best is not None and best.aligned else {}
    unjudged = _why_unjudged(best, apart, fitted, fit)
    ceiling = point_ceiling(len(pts), float(samples.area.sum()), JUDGING_RADIUS_M)
    cover = {}
    if not unjudged and ceiling < SURFACE_MIN:
        with progress.stage("what the registered photos see"):
            cover = photo_cover(best, samples, scene.rays, fit_matrix)
        missing_mask = np.zeros(len(samples.points), dtype=bool)
        missing_mask[cover["judged"][cover["views"] < 2]] = True
        cover = {"pct": cover["pct"], "by_class_pct": cover["by_class_pct"]}
    missing = {c: float(samples.area[missing_mask & (classes == c)].sum()) for c in sorted(set(classes))}
    if cover:  # judged on a subset: the missing area is the share not seen, of each class's area
        area = surface["class_area_m2"]
        missing = {c: float(area.get(c, 0.0) * (1.0 - v / 100.0)) for c, v in cover["by_class_pct"].items()}
    result = Check(sim, route, names, left_out, shift, fitted, missing, residual, unjudged=unjudged,
                   photo_cover=cover, point_ceiling_pct=ceiling,
                   cameras=[f"{g.label} ({len(g.names)} photos)" for g in cameras], lost=lost)
    if result.unjudged:
        progress.note(f"no verdict on the surface: {result.unjudged}")
    _write(result, scene, samples, missing_mask, classes, out_dir)
    return result


def _write(result: Check, scene, samples, missing_mask, classes, out_dir: Path) -> None:
    (out_dir / "check.json").write_text(json_text(result.to_dict()))
    if len(result.simulation.model_points):
        trimesh.PointCloud(result.simulation.model_points).export(out_dir / "check.points.ply")
    gone = samples.points[missing_mask]
    if len(gone):
        trimesh.PointCloud(gone).export(out_dir / "missing.ply")
    lon, lat, h = geo.to_lonlat(scene.frame, gone) if len(gone) else (np.zeros(0),) * 3
    features = [{"type": "Feature", "geometry": {"type": "Point", "coordinates": [round(float(a), 9),
                                                                                  round(float(b), 9), round(float(c), 3)]},
                 "properties": {"class": str(k)}} for a, b, c, k in zip(lon, lat, h, classes[missing_mask])]
    (out_dir / "missing.geojson").write_text(json_text({"type": "FeatureCollection", "features": features}, indent=None))
