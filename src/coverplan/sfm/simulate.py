"""simulate(): render a route's photos on the scene, run SfM on them, and say what came back.

The judge of a plan is a reconstruction (docs/design.md): photos registered in the largest model,
number of models, 3D points, reprojection and camera-centre errors, and the share of the
target surface with a 3D point within 0.1 m and 0.2 m, overall and per surface class.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from coverplan.equipment.drones import DRONES, drone_of_route
from coverplan.equipment.lens import PINHOLE, Lens
from coverplan.errors import ParameterError
from coverplan.progress import Progress
from coverplan.sfm.colmap import MAX_FEATURES, SPATIAL_NEIGHBOURS, check_matching, require_pycolmap, run_sfm
from coverplan.sfm.conditions import Conditions, fly, get_conditions
from coverplan.sfm.field_render import FieldRenderer
from coverplan.sfm.judge import judge_samples, reconstructed_surface
from coverplan.sfm.mapping import check_mapper
from coverplan.sfm.pairs import covisible_pairs
from coverplan.sfm.render import PhotoCamera, check_texture, ground_reach, ideal_renderer
from coverplan.sfm.simulation import Simulation

DEFAULT_WIDTH_PX = 1024
JUDGE_SPACING_M = 0.1
PAIRS_PER_PHOTO = 60  # matched per photo in flights too large for exhaustive matching (30 split fig411)


def photo_names(n: int) -> list[str]:
    """The file names of a simulated flight's ``n`` photos, in route order (COLMAP's image names).

    Parameters
    ----------
    n : int
        Photos.

    Returns
    -------
    list of str
        Names.
    """
    return [f"shot_{k:04d}.png" for k in range(n)]


LENSES = ("pinhole", "drone")


def photo_lens(kind: str, route) -> Lens:
    """The lens ``simulate`` draws the route's photos through: a pinhole, or ("drone") the
    distortion of the route's drone profile; a one-line error when the route has none.

    Parameters
    ----------
    kind : {"pinhole", "drone"}
        The lens asked.
    route : Route
        Its drone profile gives the lens.

    Returns
    -------
    Lens
        The lens.

    Raises
    ------
    ParameterError
        ``drone`` for a route without a profile, or whose drone's lens has no published distortion.
    """
    if kind not in LENSES:
        raise ParameterError(f"unknown lens {kind!r}; choose one of {', '.join(LENSES)}")
    if kind == "pinhole":
        return PINHOLE
    drone = drone_of_route(route)
    with_lens = sorted(name for name, d in DRONES.items() if not d.lens.is_pinhole)
    if drone is None or drone.lens.is_pinhole:
        what = "names no drone profile" if drone is None else f"is for the {drone.label}, whose lens has no "                                                               "published distortion"
        raise ParameterError(f"--lens drone: the route {what}; plan it with --drone {' / '.join(with_lens)}, "
                             "or simulate with --lens pinhole")
    return drone.lens


DEFAULT_CONDITIONS = "field"
RENDER_THREADS = 2
DEFAULT_DRAWS = 3


def simulate(route, scene, out_dir, *, conditions: str = DEFAULT_CONDITIONS, draws: int = DEFAULT_DRAWS,
             texture: str = "noise", matching: str = "spatial", width: int = DEFAULT_WIDTH_PX, threads: int = -1, seed: int = 0,
             exhaustive_limit: int = 80, spatial_neighbours: int = SPATIAL_NEIGHBOURS,
             judge_spacing: float = JUDGE_SPACING_M, mapper: str = "auto", max_features: int = MAX_FEATURES,
             lens: str = "pinhole", progress: Progress | None = None, announce=None) -> Simulation:
    """Render the route's photos as a drone would take them, reconstruct them, judge the result.

    Parameters
    ----------
    route : Route
        Its photos, and those it was planned around (``params.existing_photos``) after them.
    scene : Scene
        The true scene: the photos are rendered on it and the reconstruction judged against it.
    out_dir : path
        Photos and COLMAP's files; with several draws, one folder ``draw-K`` each.
    conditions : {"ideal", "field", "harsh"} or Conditions
        ``field`` flies with the drone profile's position, heading and gimbal error in a moving
        light (sfm/conditions.py); ``harsh`` adds plaster, brick, window grids, glass and tiles.
    draws : int
        Flights drawn under the conditions, seeds ``seed`` .. ``seed + draws - 1``; the returned
        verdict is the worst draw's, with every draw's summary in ``Simulation.draws``. ``ideal``
        is one draw whatever is asked.
    texture : {"noise", "cells"}
        The texture family under field or harsh conditions.
    matching : {"spatial", "covisible"}
        Above ``exhaustive_limit`` photos: COLMAP's spatial matcher on the photos' GNSS tags (as a
        user would run it) with ``spatial_neighbours`` per photo, or the pairs whose rendered
        views share most surface.
    mapper : {"auto", "incremental", "global"}
        COLMAP's incremental mapper, its global one (GLOMAP), or "auto": the global one for
        flights of more than ``mapping.GLOBAL_MAPPING_ABOVE`` photos.
    max_features : int
        SIFT features per photo (COLMAP's default 8192). Fewer match faster and rebuild less.
    lens : {"pinhole", "drone"}
        The photos drawn through a pinhole, or through the drone profile's own lens distortion
        (``DroneProfile.lens``), reconstructed with that lens as COLMAP's FULL_OPENCV camera.
    width : int
        Width of the rendered photos in px (the field of view kept).
    threads : int
        Threads for COLMAP (-1: every core).
    seed : int
        The first draw's seed.
    exhaustive_limit : int
        Up to this many photos every pair is matched.
    spatial_neighbours : int
        Spatial matching's neighbours per photo.
    judge_spacing : float
        Spacing (m) of the samples the model is judged on.
    progress : Progress, optional
        Bars and stage timings.
    announce : callable, optional
        Called once the settings are checked, before the long work (the CLI tells the estimated
        time there).

    Returns
    -------
    Simulation
        The worst draw.

    Raises
    ------
    ParameterError
        Without pycolmap (``pip install 'coverplan[sfm]'``), or with impossible sizes.
    SfmError
        A COLMAP stage failed; what it wrote is kept.

    Examples
    --------
    >>> import coverplan  # doctest: +SKIP
    >>> scene = coverplan.load_scene("meshes/gabled_house.obj")  # doctest: +SKIP
    >>> route = coverplan.plan(scene, coverplan.get_camera("phantom4pro"), gsd=0.004, security=3.0)  # doctest: +SKIP
    >>> sim = coverplan.simulate(route, scene, "house_sim", draws=1, width=640)  # doctest: +SKIP
    >>> sim.models, sim.registered == sim.photos  # doctest: +SKIP
    (1, True)
    """
    require_pycolmap()
    cond = conditions if isinstance(conditions, Conditions) else get_conditions(conditions)
    check_texture(texture)
    check_matching(matching)
    check_mapper(mapper)
    draws = 1 if cond.name == "ideal" else int(draws)
    if draws < 1:
        raise ParameterError(f"draws must be at least 1, got {draws}")
    if int(max_features) != max_features or max_features < 100:
        raise ParameterError(f"SIFT features per photo must be a whole number of at least 100, got {max_features!r}")
    if int(spatial_neighbours) != spatial_neighbours or spatial_neighbours < 1:
        raise ParameterError(f"spatial neighbours (--neighbours) must be a whole number of at least 1, "
                             f"got {spatial_neighbours!r}")
    lens_drawn = photo_lens(lens, route)
    route = route.with_existing_photos()  # planned around photos already taken: SfM gets old and new
    if len(route.shots) < 2:
        raise ParameterError(f"the route has {len(route.shots)} photo(s); SfM needs at least 2")
    progress = progress or Progress()
    if announce is not None:
        announce()
    out_dir = Path(out_dir)
    folders = [out_dir] if draws == 1 else [out_dir / f"draw-{k + 1}" for k in range(draws)]
    runs = []
    for k, folder in enumerate(folders):
        progress.note(f"draw {k + 1} of {draws} ({cond.name}, {texture} textures)")
        runs.append(_simulate_once(route, scene, folder, cond, texture, matching, width, threads, seed + k,
                                   exhaustive_limit, spatial_neighbours, judge_spacing, mapper, int(max_features),
                                   progress, lens_drawn))
    worst = min(range(draws), key=lambda k: runs[k].severity)
    sim = runs[worst]
    sim.draws = [dict(r.summary(), seed=seed + k, folder=str(folders[k])) for k, r in enumerate(runs)]
    sim.worst_draw = worst
    return sim


def _simulate_once(route, scene, out_dir: Path, cond, texture: str, matching: str, width: int, threads: int, seed: int,
                   exhaustive_limit: int, spatial_neighbours: int, judge_spacing: float, mapper: str, max_features: int,
                   progress: Progress, lens: Lens = PINHOLE) -> Simulation:
    images = out_dir / "images"
    images.mkdir(parents=True, exist_ok=True)
    shots = route.shots
    photo = PhotoCamera.of(route.camera, width, lens)
    d_opt = route.d_opt
    flown = fly(route, cond, seed=seed)
    if cond.physical_textures:
        renderer = FieldRenderer(scene, photo, ground_reach=ground_reach(d_opt, route.security), family=texture,
                                 facades=cond.facades, seed=seed, metering=cond.metering)
    else:
        renderer = ideal_renderer(scene, photo, d_opt, route.security, seed=seed)
    names = photo_names(len(shots))
    t = time.perf_counter()
    from PIL import Image  # the sfm extra

    def render(k: int) -> np.ndarray:
        if cond.light:  # each photo its own noise stream: the same photos however many threads
            img, pts = renderer.render_flown(flown.positions[k], flown.heading_deg[k], flown.pitch_deg[k],
                                             flown.sun[k], flown.direct[k], flown.exposure[k], flown.velocity[k],
                                             flown.shutter_s, np.random.default_rng([seed, 0xCA3E, k]))
        else:
            img, pts = renderer.render_with_points(flown.positions[k], flown.heading_deg[k], flown.pitch_deg[k])
        Image.fromarray(img).save(images / names[k])
        return pts

    # Embree and most of numpy release the GIL: two threads render nearly twice as fast.
    with progress.stage("rendering photos", total=len(shots), unit="img") as tick, \
            ThreadPoolExecutor(max_workers=RENDER_THREADS) as pool:
        seen = []
        for pts in pool.map(render, range(len(names))):
            seen.append(pts)
            tick(1)
    seconds = {"render": time.perf_counter() - t}
    centres = flown.positions  # where the photos were really taken: the judge's reference
    pairs = covisible_pairs(seen, cell=max(0.25 * d_opt, 0.5), k=PAIRS_PER_PHOTO) \
        if len(shots) > exhaustive_limit and matching == "covisible" else []
    sfm = run_sfm(images, names, photo, centres, pairs, out_dir / "colmap", exhaustive_limit=exhaustive_limit,
                  threads=threads, seed=seed, progress=progress, matching=matching, recorded_positions=flown.recorded,
                  neighbour_distance=max(3.0 * d_opt, 10.0), neighbours=spatial_neighbours, mapper=mapper,
                  max_features=max_features)
    seconds.update(sfm.seconds)
    best = sfm.largest
    t = time.perf_counter()
    with progress.stage("judging the reconstruction"):
        samples = judge_samples(scene, judge_spacing)
        pts = best.points if best is not None and best.aligned else np.zeros((0, 3))
        surface = reconstructed_surface(samples, pts)
    seconds["judge"] = time.perf_counter() - t
    registered = set(best.image_names) if best is not None else set()
    shot_registered = np.array([n in registered for n in names])
    centre_error = best.centre_error_m(names, centres) if best is not None \
        else {"median": float("nan"), "max": float("nan")}
    distance = surface.pop("nearest_point_m")
    surface.pop("classes")
    return Simulation(
        photos=len(shots), registered=len(registered),
        registered_any=len(set().union(*[m.image_names for m in sfm.models])) if sfm.models else 0,
        models=len(sfm.models), points=int(len(best.points)) if best is not None else 0,
        reprojection_error_px=best.reprojection_error_px if best is not None else float("nan"),
        centre_error_m=centre_error, surface=surface, photo_width_px=photo.width, seconds=seconds,
        shot_registered=shot_registered, sample_points=samples.points, sample_distance=distance,
        model_points=pts, conditions=cond.name, texture=texture if cond.physical_textures else "ideal",
        flown_offset_m={"median": float(np.median(flown.offset_m)), "max": float(flown.offset_m.max())},
        mapper=sfm.mapper)
