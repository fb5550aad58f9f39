"""Command line: argument parsing and error reporting only; the work is in the modules."""

from __future__ import annotations

import argparse
import json
import sys

from coverplan import __version__
from coverplan.batch.run import BatchSettings, parse_where, run_batch
from coverplan.cli.summary import plan_summary
from coverplan.equipment.camera import PRESETS, Camera, check_positive, get_camera
from coverplan.equipment.drones import drones_table, get_drone, security_shortfall
from coverplan.equipment.flighttime import FlightModel
from coverplan.errors import CoverplanError, ParameterError
from coverplan.evaluation import evaluate
from coverplan.flight.missions import mission_to_route
from coverplan.flight.route import Route
from coverplan.flight.tour import DEFAULT_LANE_STEPS, DEFAULT_REAIM_STEPS, DEFAULT_REVERSAL_STEPS
from coverplan.geometry.geo import check_crs
from coverplan.io import GEOGRAPHIC_FORMATS, export_route, parse_formats, read_mission
from coverplan.io.load import _check_geodetic_origin, load_scene
from coverplan.io.qgc import PX4_MISSION_ITEMS
from coverplan.io.zones import read_zones
from coverplan.job import run_job, write_pictures
from coverplan.planning.settings import DEFAULT_CEILING_M, LP_TIME_LIMIT_S, SELECTIONS
from coverplan.progress import Progress
from coverplan.sfm.check import check as check_photos
from coverplan.sfm.colmap import GLOBAL_MAPPING_ABOVE, MAX_FEATURES, SPATIAL_NEIGHBOURS
from coverplan.sfm.existing import read_existing
from coverplan.sfm.simulate import Simulation, simulate
from coverplan.shots.reconstructability import LINK_TESTS, MatchRule
from coverplan.world.merge import merge_into_target
from coverplan.world.pointcloud import parse_classes


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors and exit status 2."""

    def error(self, message):
        sys.stderr.write(f"{self.prog}: error: {message} (see {self.prog} --help)\n")
        sys.exit(2)


def _add_scene_args(p, targets_positional: bool):
    if targets_positional:
        p.add_argument("targets", nargs="+", metavar="TARGET", help="target mesh file(s)")
    else:
        p.add_argument("--target", "--targets", dest="targets", nargs="+", required=True, metavar="TARGET",
                       help="target mesh file(s)")
    p.add_argument("--obstacles", nargs="+", default=[], metavar="MESH", help="obstacle mesh file(s)")
    p.add_argument("--units", default=None, choices=["m", "cm", "mm", "ft", "in"],
                   help="units of the mesh files (default: the CRS's unit, else m)")
    p.add_argument("--ground", type=float, default=None, metavar="Z",
                   help="ground height in metres (default: lowest point of the target)")
    p.add_argument("--terrain", default=None, metavar="DTM",
                   help="ground heights as a raster (GeoTIFF, any CRS; heights in the models' height system): "
                        "the minimum altitude follows it (needs coverplan[terrain])")
    p.add_argument("--target-names", nargs="+", default=None, metavar="NAME",
                   help="in multi-object target files, the objects that are targets (others are obstacles)")
    p.add_argument("--up-axis", choices=["y", "z"], default=None,
                   help="up axis of the mesh files (default z; glTF/GLB default y)")
    p.add_argument("--building", default=None, metavar="ID",
                   help="CityGML/CityJSON: id of the target building (the others nearby become obstacles)")
    p.add_argument("--lod", type=int, default=None, help="CityGML/CityJSON: level of detail (default: highest)")
    p.add_argument("--context-radius", type=float, default=None, metavar="M",
                   help="CityGML/CityJSON: city objects within this distance become obstacles (default 150)")
    p.add_argument("--crs", default=None, metavar="EPSG:XXXX",
                   help="projected CRS of mesh coordinates that carry none (for geographic exports)")
    p.add_argument("--geo-origin", nargs=3, type=float, default=None, metavar=("LAT", "LON", "H"),
                   help="or: the geodetic position of the mesh frame's origin (x east, y north, z up)")
    p.add_argument("--height-attribute", default=None, metavar="NAME",
                   help="footprints (GeoJSON, GeoPackage, Shapefile): the attribute with each building's height in m")
    p.add_argument("--height", type=float, default=None, metavar="M",
                   help="footprints: the height of those without the attribute (or of all)")
    p.add_argument("--roof-attribute", default=None, metavar="NAME",
                   help="footprints: ridge height above the eaves in m, for a gable roof (default flat)")
    p.add_argument("--obstacle-points", nargs="+", default=[], metavar="CLOUD",
                   help="LAS/LAZ/PLY point clouds (trees, wires, ...) in the meshes' coordinates, as obstacles")
    p.add_argument("--points-resolution", type=float, default=0.5, metavar="M",
                   help="voxel size the point clouds are turned into obstacles at (default 0.5)")
    p.add_argument("--point-classes", default=None, metavar="C,C,...",
                   help="LAS classes to keep, e.g. 3,4,5,14 (default: all but ground 2 and noise 7, 18)")


def _scene(args):
    return load_scene(args.targets, args.obstacles, units=args.units, ground=args.ground,
                      target_names=args.target_names, up_axis=args.up_axis, building=args.building,
                      lod=args.lod, context_radius=args.context_radius, crs=args.crs,
                      geodetic_origin=args.geo_origin, obstacle_points=args.obstacle_points,
                      points_resolution=args.points_resolution, point_classes=parse_classes(args.point_classes),
                      height_attribute=args.height_attribute, height=args.height, roof_attribute=args.roof_attribute,
                      terrain=args.terrain)


def _camera(args) -> Camera:
    drone = _drone(args)
    if args.camera and any(v is not None for v in (args.sensor_mm, args.focal_mm, args.image_px)):
        raise ParameterError("give either --camera or --sensor-mm/--focal-mm/--image-px, not both")
    if drone is not None and (args.camera or args.sensor_mm is not None):
        raise ParameterError(f"--drone {drone.name} brings its camera ({drone.camera.name}); leave out --camera "
                             "and --sensor-mm/--focal-mm/--image-px")
    if drone is not None:
        return drone.camera
    if args.camera:
        return get_camera(args.camera)
    if args.sensor_mm is None or args.focal_mm is None or args.image_px is None:
        raise ParameterError("give a camera: --camera PRESET, or all of --sensor-mm W H --focal-mm F "
                             f"--image-px W H (presets: {', '.join(sorted(PRESETS))}), or a --drone")
    return Camera(args.sensor_mm[0], args.sensor_mm[1], args.focal_mm, args.image_px[0], args.image_px[1])


def _drone(args):
    name = getattr(args, "drone", None)
    return get_drone(name) if name else None


def _flight_model(args):
    """The flight-time model: the drone's (at --speed if given), else generic at --speed."""
    drone = _drone(args)
    speed = None if args.speed is None else check_positive("--speed", args.speed)
    model = drone.flight_model(speed) if drone is not None else FlightModel(cruise_speed=speed or 5.0)
    if getattr(args, "shot_seconds", None) is not None:  # export has no photos to time
        from dataclasses import replace
        if not args.shot_seconds >= 0:
            raise ParameterError(f"--shot-seconds must be >= 0, got {args.shot_seconds}")
        model = replace(model, photo_seconds=float(args.shot_seconds))
    return model


def _export_options(args) -> dict:
    return {"firmware": args.firmware, "speed": _flight_model(args).cruise_speed, "drone": _drone(args),
            "wpml_heights": args.wpml_heights}


def cmd_drones(args) -> int:
    print(drones_table())
    print("flight min: usable of rated (30 % kept in reserve); the first is the default --max-flight-min. "
          "Sources: docs/flights.md")
    return 0


def cmd_cameras(args) -> int:
    print(f"{'name':<15}{'sensor mm':>14}{'focal mm':>10}{'image px':>13}{'HFOV':>8}{'VFOV':>8}")
    for name, cam in sorted(PRESETS.items()):
        print(f"{name:<15}{cam.sensor_width_mm:>7.2f} x{cam.sensor_height_mm:>5.2f}{cam.focal_length_mm:>10.2f}"
              f"{cam.image_width_px:>7d}x{cam.image_height_px:<5d}{cam.hfov_deg:>7.1f}°{cam.vfov_deg:>7.1f}°")
    return 0


def cmd_evaluate(args) -> int:
    if args.spacing is not None:
        check_positive("--spacing", args.spacing)
    scene = _scene(args)
    if args.route.lower().endswith(".json"):
        if args.gsd is not None or args.security is not None:
            raise ParameterError("a route file carries its own camera, GSD and security distance; "
                                 "--camera/--gsd/--security are for missions from other apps")
        route = Route.load(args.route)
    else:
        route = _mission_route(args, scene)
    if args.max_altitude is not ROUTE_CEILING:  # judged against a ceiling given here instead of the route's own
        route.params["max_altitude_m"] = args.max_altitude
    if args.keep_out or args.keep_in:  # judged against these zones instead of the route's own
        route.params["zones"] = read_zones(args.keep_out, args.keep_in, scene).to_list()
    progress = Progress(bars=not args.json)
    with progress.stage("evaluate", total=len(route.shots), unit="shot") as update:
        ev = evaluate(route, scene, spacing=args.spacing, progress=update)
    if args.json:
        print(json.dumps(ev.metrics, indent=1, default=float))
    else:
        print(ev.table())
    if args.strict:
        failed = []
        if not ev.safe:
            failed.append("the route is not safe")
        if args.min_coverage is not None and ev.coverage_pct < args.min_coverage:
            failed.append(f"coverage {ev.coverage_pct:.2f} % is below {args.min_coverage} %")
        if failed:
            print(f"coverplan: strict check failed: {'; '.join(failed)}", file=sys.stderr)
            return 1
    return 0


def _mission_route(args, scene):
    """A QGroundControl / Mission Planner / Litchi mission as a route in the scene's frame."""
    missing = [flag for flag, v in (("--gsd", args.gsd), ("--security", args.security)) if v is None]
    if missing or not (args.camera or args.sensor_mm):
        need = missing + ([] if (args.camera or args.sensor_mm) else ["--camera"])
        raise ParameterError(f"{args.route} is a mission from another app: give {', '.join(need)} "
                             "(the camera it flies, the GSD and security distance to judge it by)")
    route = mission_to_route(read_mission(args.route), scene, _camera(args), check_positive("--gsd", args.gsd),
                             check_positive("--security", args.security))
    for note in route.extra["notes"]:  # what the file left open, and how it was read
        print(f"coverplan: {note}", file=sys.stderr)
    return route


def _add_camera_args(p):
    p.add_argument("--camera", default=None, metavar="PRESET",
                   help=f"camera preset: {', '.join(sorted(PRESETS))} (see 'coverplan cameras')")
    p.add_argument("--sensor-mm", nargs=2, type=float, default=None, metavar=("W", "H"))
    p.add_argument("--focal-mm", type=float, default=None, metavar="F")
    p.add_argument("--image-px", nargs=2, type=float, default=None, metavar=("W", "H"))


def cmd_plan(args) -> int:
    from pathlib import Path


    out = Path(args.output)
    if out.exists() and not args.force:
        raise ParameterError(f"{out} exists; pass --force to overwrite it")
    if not out.parent.exists():
        raise ParameterError(f"{out.parent} does not exist (output folder for {out.name})")
    camera = _camera(args)
    formats = parse_formats(args.export)
    progress = Progress(bars=not args.quiet, verbose=args.verbose)
    with progress.stage("load scene"):
        scene = _scene(args)
        if args.merge_obstacles_within is not None:
            if args.merge_obstacles_within < 0:
                raise ParameterError(f"--merge-obstacles-within must be >= 0, got {args.merge_obstacles_within}")
            scene = merge_into_target(scene, args.merge_obstacles_within)
    for note in scene.notes:  # say it now, before the long work, not only in the summary
        if note.startswith("WARNING"):
            print(f"coverplan: {note}", file=sys.stderr)
    if set(formats) & GEOGRAPHIC_FORMATS and not (scene.crs or scene.geodetic_origin):
        raise ParameterError(f"{', '.join(sorted(set(formats) & GEOGRAPHIC_FORMATS))} export needs a georeference: "
                             "the input has no CRS; pass --crs EPSG:XXXX or --geo-origin LAT LON H")
    if args.strict:
        shortfall = security_shortfall(args.security, _drone(args))
        if shortfall:
            raise ParameterError(f"{shortfall} (--strict)")
    # --start is in the input models' coordinates, like the meshes: move it with them.
    start = None if args.start is None else scene.to_local(args.start)
    options = _plan_options(args, formats)
    if args.existing:
        with progress.stage("existing photos"):
            options["existing"] = read_existing(args.existing, scene, camera, args.gsd, args.security, progress)
    job = run_job(scene, camera, out, formats=formats, export_options=_export_options(args), evaluated=args.evaluate,
                  report=args.report, plot=args.plot, start=start, progress=progress, **options)
    route, ev, written = job.route, job.evaluation, job.written
    if job.exports_withheld:
        print("coverplan: the evaluator found the route unsafe; no mission was exported", file=sys.stderr)
    if not args.quiet:
        print(plan_summary(route))
        print("written: " + ", ".join(str(p) for p in written))
    if args.simulate:
        code = _simulate(route, scene, args.simulate, args)
        if args.report:
            write_pictures(route, scene, ev, args.report, args.plot, progress,
                           Simulation.load(Path(args.simulate) / "simulation.json"))
        return code
    return 0


def _plan_options(args, formats: list[str]) -> dict:
    """planner.plan's keyword arguments from the planning flags ``plan`` and ``batch`` share;
    ``formats``: the exports asked (``parse_formats(args.export)``)."""
    items = args.max_mission_items
    if items is None and "qgc" in formats and args.firmware == "px4":
        items = PX4_MISSION_ITEMS  # a longer flight would be refused at export
    return dict(gsd=args.gsd, security=args.security, min_views=args.min_views,
                min_triangulation_deg=args.min_triangulation_deg, rule=args.rule, match=_match_rule(args),
                max_incidence_deg=args.max_incidence_deg, min_altitude=args.min_altitude, max_altitude=args.max_altitude,
                spacing=args.spacing,
                gimbal_pitch_range_deg=_gimbal(args), drone=_drone(args), flight_model=_flight_model(args),
                max_flight_min=args.max_flight_min, max_mission_items=items,
                lp_time_limit=args.lp_time_limit, surface_classes=args.only, pose_margin=args.margin,
                keep_out=tuple(args.keep_out), keep_in=tuple(args.keep_in), zone_margin=args.zone_margin,
                fly=args.fly, view_tilts=args.view_tilts,
                edge_views=None if args.edge_views is None else args.edge_views == "on",
                reversal_steps=args.reversal_cost, reaim_steps=args.reaim_cost,
                selection=args.selection, forward_overlap=args.forward_overlap, side_overlap=args.side_overlap,
                lane_steps=args.lane_cost,
                max_memory=None if args.max_memory_gb is None
                else check_positive("--max-memory-gb", args.max_memory_gb) * 1e9)


ROUTE_CEILING = object()  # evaluate's default: the ceiling the route records


def _ceiling(text: str) -> float | None:
    if text.strip().lower() == "none":
        return None
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected metres or 'none', got {text!r}") from None


def _gimbal(args):
    """The gimbal range given on the command line (None: the drone's, or -90..30)."""
    if args.gimbal_min_deg is None and args.gimbal_max_deg is None:
        return None
    drone = _drone(args)
    lo, hi = drone.gimbal_pitch_deg if drone is not None else (-90.0, 30.0)
    return (lo if args.gimbal_min_deg is None else args.gimbal_min_deg,
            hi if args.gimbal_max_deg is None else args.gimbal_max_deg)


def cmd_batch(args) -> int:

    if args.workers is not None and args.workers < 1:
        raise ParameterError(f"--workers must be at least 1, got {args.workers}")
    if args.workers is not None and args.scheduler:
        raise ParameterError("give either --workers (a local cluster) or --scheduler (a running one), not both")
    if args.merge_obstacles_within is not None and args.merge_obstacles_within < 0:
        raise ParameterError(f"--merge-obstacles-within must be >= 0, got {args.merge_obstacles_within}")
    if args.buildings and (args.all or args.bbox or args.where):
        raise ParameterError("--buildings names the buildings; it does not combine with --all, --bbox or --where")
    formats = parse_formats(args.export)
    settings = BatchSettings(camera=_camera(args), plan_options=_plan_options(args, formats), exports=formats,
                             export_options=_export_options(args), report=args.report,
                             merge_obstacles_within=args.merge_obstacles_within,
                             context_radius=args.context_radius, lod=args.lod, terrain=args.terrain)
    progress = Progress(bars=not args.quiet)
    result = run_batch(args.city, args.output, settings, buildings=args.buildings, everything=args.all,
                       bbox=args.bbox, where=parse_where(args.where), workers=args.workers,
                       scheduler=args.scheduler, progress=progress, log_lines=not args.quiet)
    failed = result.failed
    if not args.quiet:
        planned = len(result.rows) - len(failed)
        rate = 60.0 * result.planned_now / result.seconds if result.seconds > 0 else 0.0
        print(f"{len(result.rows)} buildings: {planned} planned"
              + (f" ({result.skipped} already complete)" if result.skipped else "")
              + (f", {len(failed)} not planned" if failed else "")
              + f"; {result.seconds:.1f} s, {rate:.1f} buildings/min")
        for row in failed[:5]:
            print(f"  {row['id']}: {row.get('status')}: {row.get('error', '')}")
        if len(failed) > 5:
            print(f"  ... and {len(failed) - 5} more (summary.csv)")
        print("written: " + ", ".join(str(p) for p in result.written))
    return 1 if failed else 0


def _match_rule(args):
    """The sfm rule's settings from the command line (None: the defaults)."""

    given = {k: v for k, v in (("max_pair_deg", args.max_pair_deg), ("min_overlap", args.min_overlap),
                               ("min_neighbours", args.min_neighbours), ("sharp_views", args.sharp_views),
                               ("framed_views", args.framed_views), ("link_test", args.link_test),
                               ("braced", None if args.links is None else args.links == "braced"))
             if v is not None}
    if not given:
        return None
    if args.rule != "sfm":
        flag = {"braced": "links"}.get(next(iter(given)), next(iter(given)))
        raise ParameterError(f"--{flag.replace('_', '-')} belongs to --rule sfm")
    return MatchRule(**given)


def cmd_check(args) -> int:
    from pathlib import Path

    gsd, security = check_positive("--gsd", args.gsd), check_positive("--security", args.security)
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise ParameterError(f"{out} exists and is not a folder")
    scene = _scene(args)
    progress = Progress(bars=not args.quiet, verbose=args.verbose)
    result = check_photos(args.photos, scene, out, gsd=gsd, security=security, threads=args.threads, fit=args.fit,
                          mapper=args.mapper, progress=progress)
    for name, why in result.left_out:
        print(f"coverplan: {name} left out: {why}", file=sys.stderr)
    if args.report:
        with progress.stage("evaluate"):
            ev = evaluate(result.route, scene)
        write_pictures(result.route, scene, ev, args.report, None, progress, result.simulation)
    if args.json:
        print(json.dumps(result.to_dict(), indent=1, default=float))
    elif not args.quiet:
        print(result.table())
        print(f"written: {out / 'check.json'}, {out / 'missing.ply'}, {out / 'missing.geojson'}"
              + (f", {args.report}" if args.report else ""))
    return 1 if args.strict and not result.simulation.reconstructable else 0


def cmd_simulate(args) -> int:
    route = Route.load(args.route)
    scene = _scene(args)
    return _simulate(route, scene, args.output, args)


def _simulate(route, scene, out_dir, args) -> int:
    """Render, reconstruct and judge; prints the table (or JSON), exit 1 under --strict when
    the flight would not reconstruct."""
    from pathlib import Path


    width = int(check_positive("--photo-width", args.photo_width))
    if width < 160:
        raise ParameterError(f"--photo-width must be at least 160 px, got {width}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ParameterError(f"{out} exists and is not a folder")
    progress = Progress(bars=not getattr(args, "quiet", False), verbose=getattr(args, "verbose", False))
    if args.draws < 1:
        raise ParameterError(f"--draws must be at least 1, got {args.draws}")
    sim = simulate(route, scene, out, conditions=args.conditions, draws=args.draws, texture=args.texture,
                   matching=args.matching, mapper=args.mapper, spatial_neighbours=args.neighbours,
                   max_features=args.max_features, width=width, threads=args.threads, progress=progress)
    sim.save(out / "simulation.json")
    if getattr(args, "json", False):
        print(json.dumps(sim.to_dict(), indent=1, default=float))
    elif not getattr(args, "quiet", False):
        print(sim.table())
        print(f"written: {out / 'simulation.json'}, photos in {out / 'images'}")
    if getattr(args, "strict", False) and not sim.reconstructable:
        print("coverplan: strict check failed: the photos do not reconstruct (see the table)", file=sys.stderr)
        return 1
    return 0


def _add_mapper_arg(p):
    p.add_argument("--mapper", default="auto", choices=("auto", "incremental", "global"),
                   help="COLMAP's incremental mapper or its global one (GLOMAP); auto (default): global above "
                        f"{GLOBAL_MAPPING_ABOVE} photos, where the incremental one split flights that the global "
                        "one kept whole")


def _add_simulate_args(p):
    p.add_argument("--photo-width", type=int, default=1024, metavar="PX",
                   help="width of the rendered photos (field of view kept; default 1024)")
    p.add_argument("--conditions", default="field", choices=("ideal", "field", "harsh"),
                   help="ideal: the planned poses, fixed light; field (default): the drone profile's GNSS/RTK, "
                        "heading and gimbal error, moving sun and shadows, clouds, exposure, noise, blur; "
                        "harsh: field plus plaster, brick, window grids, glass and roof tiles")
    p.add_argument("--draws", type=int, default=3, metavar="N",
                   help="flights drawn under the conditions; the verdict is the worst (default 3)")
    p.add_argument("--matching", default="spatial", choices=("spatial", "covisible"),
                   help="pairs matched in flights over 80 photos: spatial (default, COLMAP's spatial matcher on the "
                        "photos' GNSS tags, as you would run it) or covisible (pairs whose rendered views overlap)")
    p.add_argument("--neighbours", type=int, default=SPATIAL_NEIGHBOURS, metavar="N",
                   help=f"spatial matching: each photo is matched with its N nearest (default {SPATIAL_NEIGHBOURS}; "
                        "fewer match faster, for flights of many hundred photos)")
    p.add_argument("--max-features", type=int, default=MAX_FEATURES, metavar="N",
                   help=f"SIFT features per photo at most (default {MAX_FEATURES}, COLMAP's; fewer match and map "
                        "faster)")
    _add_mapper_arg(p)
    p.add_argument("--texture", default="noise", choices=("noise", "cells"),
                   help="texture family under field/harsh conditions: noise (value noise) or cells (cellular stone)")
    p.add_argument("--threads", type=int, default=-1, help="threads for SfM (default: all cores)")


def cmd_report(args) -> int:
    if not args.report and not args.plot:
        raise ParameterError("give -o REPORT.html and/or --plot PREFIX")
    route = Route.load(args.route)
    scene = _scene(args)
    progress = Progress(bars=not args.quiet, verbose=args.verbose)
    with progress.stage("evaluate"):
        ev = evaluate(route, scene, spacing=args.spacing)
    simulation = None
    if getattr(args, "simulation", None):
        simulation = Simulation.load(args.simulation)
        if len(simulation.shot_registered) != len(route.shots):
            raise ParameterError(f"{args.simulation}: simulates {len(simulation.shot_registered)} photos, "
                                 f"the route takes {len(route.shots)}; is it another route's?")
    written = write_pictures(route, scene, ev, args.report, args.plot, progress, simulation)
    if not args.quiet:
        print("written: " + ", ".join(str(p) for p in written))
    return 0


def cmd_export(args) -> int:
    formats = parse_formats(args.format)
    if not formats:
        raise ParameterError("give --format with one or more of: qgc, wpl, litchi, kml, geojson, csv")
    route = Route.load(args.route)
    if args.crs or args.geo_origin:
        if args.crs and args.geo_origin:
            raise ParameterError("give either --crs or --geo-origin, not both")
        if route.frame.get("crs") and args.crs and args.crs != route.frame["crs"]:
            raise ParameterError(f"--crs {args.crs} contradicts the route's {route.frame['crs']}")
        if args.crs:
            route.frame["crs"] = check_crs(args.crs)
        else:
            route.frame["geodetic_origin"] = _check_geodetic_origin(args.geo_origin)
    stem = args.output or (args.route[:-5] if args.route.lower().endswith(".json") else args.route)
    written = export_route(route, stem, formats, **_export_options(args))
    print("written: " + ", ".join(str(p) for p in written))
    return 0


def _add_planning_args(p):
    """The camera and planning flags ``plan`` and ``batch`` share."""
    _add_camera_args(p)
    p.add_argument("--gsd", type=float, required=True, metavar="M_PER_PX", help="target ground sampling distance")
    p.add_argument("--security", type=float, required=True, metavar="M",
                   help="security distance to keep from every mesh")
    p.add_argument("--rule", choices=["sfm", "thesis"], default="sfm",
                   help="sfm (default): plan for a reconstruction (docs/reconstruction.md); "
                        "thesis: 2 views 5 deg apart, the thesis's rule, for comparison")
    p.add_argument("--margin", choices=["field", "none"], default="field",
                   help="field (default): judge frames and view-pair angles with the drone's own position, heading "
                        "and gimbal error (docs/reconstruction.md); none: the rules as given")
    p.add_argument("--fly", choices=["through", "stop"], default="through",
                   help="through (default): take photos in passing where the turn, motion blur, the photo interval "
                        "and the heading and gimbal turns allow it, and stop elsewhere (docs/flights.md); "
                        "stop: stop at every waypoint. The photos are the same")
    p.add_argument("--view-tilts", choices=["varied", "corners", "square"], default="varied",
                   help="varied (default): candidate views square-on to the surface and tilted off it; corners: "
                        "tilted only where the façade rings turn a corner; square: square-on only, so photos "
                        "along a wall share one heading (docs/flights.md, \"Lanes\")")
    p.add_argument("--edge-views", choices=["on", "off"], default=None,
                   help="on (default under --rule sfm): a photo from the bisector of the two faces every frame width "
                        "along each edge where the surface turns (a corner, an eave), seeing both faces alike "
                        "(docs/reconstruction.md, \"Edge views\"); off (default under --rule thesis): without them")
    p.add_argument("--reversal-cost", type=float, default=DEFAULT_REVERSAL_STEPS, metavar="STEPS",
                   help=f"how much path the tour gives up to avoid one reversal (a photo where the flight turns back "
                        f"by more than 90 deg and must stop), in typical steps between neighbouring photos (default "
                        f"{DEFAULT_REVERSAL_STEPS:g}; 0: the shortest tour; docs/flights.md, \"The order\")")
    p.add_argument("--reaim-cost", type=float, default=DEFAULT_REAIM_STEPS, metavar="STEPS",
                   help=f"how much path the tour gives up to fly next to each other two photos whose camera need "
                        f"not turn between them (heading within 10 deg, pitch within 5 deg), in typical steps "
                        f"(default {DEFAULT_REAIM_STEPS:g}; 0: no preference)")
    p.add_argument("--selection", choices=list(SELECTIONS), default="shots",
                   help="shots (default): photos chosen one by one from every candidate view; lanes: whole runs of "
                        "photos along façades and over roofs first, single shots only where no lane sees "
                        "(docs/flights.md, \"Lanes\")")
    p.add_argument("--forward-overlap", type=float, default=0.7, metavar="SHARE",
                   help="lanes: share of the frame consecutive photos of a lane share (default 0.7)")
    p.add_argument("--side-overlap", type=float, default=0.4, metavar="SHARE",
                   help="lanes: share of the frame neighbouring lanes (bands, roof strips) share (default 0.4)")
    p.add_argument("--lane-cost", type=float, default=DEFAULT_LANE_STEPS, metavar="STEPS",
                   help=f"lanes: how much path the tour gives up to fly each lane end to end, in typical steps "
                        f"(default {DEFAULT_LANE_STEPS:g})")
    p.add_argument("--min-views", type=int, default=None, help="views per surface point (default 3; thesis rule 2)")
    p.add_argument("--min-triangulation-deg", type=float, default=5.0)
    p.add_argument("--max-pair-deg", type=float, default=None, metavar="DEG",
                   help="sfm rule: widest view pair SfM is trusted to match (default 35)")
    p.add_argument("--min-overlap", type=float, default=None, metavar="FRACTION",
                   help="sfm rule: surface two linked photos share (default 0.3)")
    p.add_argument("--min-neighbours", type=int, default=None,
                   help="sfm rule: linked photos every photo needs (default 2)")
    p.add_argument("--links", choices=["braced", "one-piece"], default=None,
                   help="sfm rule: braced (default): no photo is the only link between two groups of photos; "
                        "one-piece: the photos only need to link into one set (the rule before December 2026)")
    p.add_argument("--link-test", choices=list(LINK_TESTS), default=None,
                   help="sfm rule: how two photos' rays to the surface both see are judged: centroid (default): "
                        "at the centroid of all of it; faces: face by face, each within 60 deg of both photos "
                        "(links across a corner count only the faces both photos see squarely); samples: point "
                        "by point, and the plan is chosen lean (fewer photos; experimental: three field draws on the "
                        "gabled house and the chapel only, docs/reconstruction.md)")
    p.add_argument("--sharp-views", type=int, default=None, metavar="N",
                   help="sfm rule: views per surface point within 35 deg of its normal, or as near as any "
                        "safe viewpoint gets plus 5 deg (default 1; 0: none asked)")
    p.add_argument("--framed-views", type=int, default=None, metavar="N",
                   help="sfm rule: views per surface point whose frame its face fills (25 %%, or most of the best "
                        "any safe viewpoint gives), within 50 deg of its normal; towers and spires get views from "
                        "closer in (default 0: none asked; try 2 for towers and spires)")
    p.add_argument("--max-incidence-deg", type=float, default=70.0)
    p.add_argument("--min-altitude", type=float, default=None, metavar="M",
                   help="lowest flight height above the ground (default: the security distance)")
    p.add_argument("--max-altitude", type=_ceiling, default=DEFAULT_CEILING_M, metavar="M|none",
                   help=f"altitude ceiling above the ground under the drone (default {DEFAULT_CEILING_M:g} m, the EU, "
                        "UK and US limit; 'none': no ceiling)")
    _add_zone_args(p)
    p.add_argument("--drone", default=None, metavar="NAME",
                   help="drone profile: camera, gimbal range, speeds, battery (see 'coverplan drones')")
    p.add_argument("--max-flight-min", type=float, default=None, metavar="MIN",
                   help="split the tour into flights of at most MIN minutes each, from the start back to it "
                        "(default: the drone's usable flight time; without --drone one flight)")
    p.add_argument("--max-mission-items", type=int, default=None, metavar="N",
                   help="split the tour so that each flight's QGC plan / WPL file has at most N mission items "
                        "(default: 500, PX4's limit, when plan exports a .plan for PX4; else no limit)")
    p.add_argument("--gimbal-min-deg", type=float, default=None, help="lowest gimbal pitch (default: the drone's, else -90)")
    p.add_argument("--gimbal-max-deg", type=float, default=None, help="highest gimbal pitch (default: the drone's, else 30)")
    p.add_argument("--spacing", type=float, default=None, metavar="M",
                   help="surface sample spacing (default d_opt/8, coarser for huge targets)")
    p.add_argument("--speed", type=float, default=None, metavar="M_PER_S",
                   help="cruise speed between waypoints (default: the drone's, else 5)")
    p.add_argument("--shot-seconds", type=float, default=None,
                   help="hover time per photo (default: the drone's photo interval, at least 1 s)")
    p.add_argument("--lp-time-limit", type=float, default=LP_TIME_LIMIT_S, metavar="S",
                   help=f"time for the LP that guides view selection and bounds it (default {LP_TIME_LIMIT_S:g}; "
                        "0: plain greedy; an LP that runs out of time is dropped, with a warning)")
    p.add_argument("--only", nargs="+", default=None, metavar="CLASS",
                   choices=["facade", "roof", "terrace", "opposed_terrace"],
                   help="cover only these surfaces (facade, roof, terrace, opposed_terrace)")
    p.add_argument("--max-memory-gb", type=float, default=None, metavar="GB",
                   help="refuse plans estimated to need more (default: 80%% of this machine's RAM)")
    p.add_argument("--merge-obstacles-within", type=float, default=None, metavar="M",
                   help="unite obstacles closer than M to the target with it (thesis Appendix C)")
    p.add_argument("--export", default=None, metavar="FORMATS",
                   help="also write flight files beside the route: qgc,wpl,litchi,wpml,kml,geojson,csv "
                        "(one per battery flight: NAME.f1.plan, ...)")
    _add_export_args(p)


def _add_zone_args(p, judged: bool = False):
    verb = "judge against" if judged else "never enter"
    p.add_argument("--keep-out", nargs="+", default=[], metavar="ZONES",
                   help=f"{verb} these polygons (GeoJSON/GeoPackage/Shapefile, WGS84 or the models' CRS; "
                        "optional floor/ceiling properties in m above the ground)")
    p.add_argument("--keep-in", nargs="+", default=[], metavar="ZONE",
                   help=f"{'judge against' if judged else 'never leave'} the union of these polygons")
    if not judged:
        p.add_argument("--zone-margin", type=float, default=None, metavar="M",
                       help="distance kept from the zones against the drone's position error (default: the drone's "
                            "horizontal accuracy, 1.5 m without --drone)")


def _add_export_args(p):
    p.add_argument("--firmware", choices=["px4", "ardupilot"], default="px4", help="for the QGC .plan")
    p.add_argument("--wpml-heights", choices=["relative", "egm96"], default="relative",
                   help="DJI WPML heights: relative to the take-off point (default) or EGM96 (needs a height "
                        "datum and PROJ's geoid grid)")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="coverplan", description="Plan safe drone photo flights that cover a building.")
    parser.add_argument("--version", action="version", version=f"coverplan {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("cameras", help="list the camera presets")
    p.set_defaults(func=cmd_cameras)

    p = sub.add_parser("drones", help="list the drone profiles (camera, gimbal, speeds, battery, apps)")
    p.set_defaults(func=cmd_drones)

    p = sub.add_parser("evaluate", help="check a route's or another app's mission's coverage and safety")
    p.add_argument("route", metavar="ROUTE",
                   help="a coverplan route (.json) or a mission: QGroundControl .plan, QGC WPL .waypoints, "
                        "Litchi .csv, DJI WPML .kmz (docs/evaluate.md)")
    _add_scene_args(p, targets_positional=False)
    _add_camera_args(p)
    p.add_argument("--gsd", type=float, default=None, metavar="M_PER_PX",
                   help="for missions: the GSD to judge the photos by")
    p.add_argument("--security", type=float, default=None, metavar="M",
                   help="for missions: the security distance to judge the flight by")
    p.add_argument("--spacing", type=float, default=None, metavar="M",
                   help="surface sample spacing in metres (default 0.25, with a seed the planner does not use)")
    p.add_argument("--max-altitude", type=_ceiling, default=ROUTE_CEILING, metavar="M|none",
                   help="judge against this altitude ceiling above the ground (default: the route's own; "
                        "missions from other apps: none)")
    _add_zone_args(p, judged=True)
    p.add_argument("--json", action="store_true", help="print the metrics as JSON")
    p.add_argument("--strict", action="store_true",
                   help="exit 1 when the route is unsafe or coverage is below --min-coverage")
    p.add_argument("--min-coverage", type=float, default=None, metavar="PCT")
    p.set_defaults(func=cmd_evaluate)

    p = sub.add_parser("plan", help="plan a safe flight covering the target surface")
    _add_scene_args(p, targets_positional=True)
    _add_planning_args(p)
    p.add_argument("--start", nargs=3, type=float, default=None, metavar=("X", "Y", "Z"),
                   help="start and end point, in the input models' coordinates (default: just outside "
                        "the shot region, north-west)")
    p.add_argument("--existing", default=None, metavar="PHOTOS_DIR|MISSION",
                   help="photos already taken (a folder of photos with GPS tags, a route .json, or a mission: "
                        "QGC .plan, .waypoints, Litchi .csv, DJI .kmz): their views count and the new flight takes "
                        "only what they do not give")
    p.add_argument("--no-evaluate", dest="evaluate", action="store_false",
                   help="skip the independent evaluation of the planned route")
    p.add_argument("-o", "--output", required=True, metavar="ROUTE.json")
    p.add_argument("--report", default=None, metavar="REPORT.html", help="also write the HTML flight report")
    p.add_argument("--plot", default=None, metavar="PREFIX", help="also write PNG figures PREFIX_*.png")
    p.add_argument("--force", action="store_true", help="overwrite an existing output file")
    p.add_argument("--strict", action="store_true",
                   help="refuse a security distance below the drone's position error bound plus 1 m; "
                        "with --simulate, exit 1 unless the photos reconstruct")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars or summary")
    p.add_argument("-v", "--verbose", action="store_true", help="log each stage's time")
    p.add_argument("--simulate", default=None, metavar="DIR",
                   help="also render the photos and reconstruct them with COLMAP into DIR (needs coverplan[sfm])")
    _add_simulate_args(p)
    p.set_defaults(func=cmd_plan)

    p = sub.add_parser("batch", help="plan every chosen building of a CityGML/CityJSON file, on Dask")
    p.add_argument("city", metavar="CITYFILE", help="CityGML (.gml) or CityJSON (.city.json, .json, .jsonl; .gz too)")
    which = p.add_argument_group("buildings (one of; --bbox and --where combine)")
    which.add_argument("--buildings", nargs="+", default=None, metavar="ID", help="these building ids")
    which.add_argument("--all", action="store_true", help="every building of the file")
    which.add_argument("--bbox", nargs=4, type=float, default=None, metavar=("XMIN", "YMIN", "XMAX", "YMAX"),
                       help="buildings centred in this box, in the file's coordinates")
    which.add_argument("--where", action="append", default=None, metavar="ATTR=VALUE",
                       help="buildings whose attribute equals VALUE (repeat: all must hold)")
    p.add_argument("--lod", type=int, default=None, help="level of detail (default: each building's highest)")
    p.add_argument("--context-radius", type=float, default=None, metavar="M",
                   help="city objects within this distance of a building are its obstacles (default 150)")
    p.add_argument("--terrain", default=None, metavar="DTM",
                   help="ground heights as a raster (GeoTIFF, any CRS; heights in the city model's height system) "
                        "instead of the city model's own ground; every worker reads it (needs coverplan[terrain])")
    _add_planning_args(p)
    p.add_argument("--no-report", dest="report", action="store_false", help="no HTML report per building")
    p.add_argument("-o", "--output", required=True, metavar="OUTDIR",
                   help="folder for buildings/ID/..., summary.csv, summary.geojson and index.html; "
                        "re-running into it skips complete buildings")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="local Dask cluster of N worker processes (default: one per core)")
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="use this running Dask scheduler instead (docs/batch.md)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")
    p.set_defaults(func=cmd_batch)

    p = sub.add_parser("simulate", help="render a route's photos, reconstruct them with COLMAP, judge the result")
    p.add_argument("route", metavar="ROUTE.json")
    _add_scene_args(p, targets_positional=False)
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="folder for photos, COLMAP files and simulation.json")
    _add_simulate_args(p)
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--strict", action="store_true",
                   help="exit 1 unless the flight is reconstructable (DESIGN.md: one model, >= 95 %% surface)")
    p.add_argument("-q", "--quiet", action="store_true")
    p.add_argument("-v", "--verbose", action="store_true")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("check", help="reconstruct a flight's real photos (EXIF/XMP positions) and say what is missing")
    p.add_argument("photos", metavar="PHOTOS_DIR")
    _add_scene_args(p, targets_positional=False)
    p.add_argument("-o", "--output", required=True, metavar="DIR",
                   help="folder for COLMAP files, check.json, missing.ply and missing.geojson")
    p.add_argument("--gsd", type=float, default=0.01, metavar="M_PER_PX",
                   help="the GSD to judge the photos' flight by in its report (default 0.01)")
    p.add_argument("--security", type=float, default=3.0, metavar="M",
                   help="the security distance to judge it by in its report (default 3)")
    p.add_argument("--report", default=None, metavar="REPORT.html", help="also write the HTML report of the flight")
    p.add_argument("--no-fit", dest="fit", action="store_false",
                   help="judge the model as aligned through the GNSS tags, without fitting it to the scene")
    p.add_argument("--threads", type=int, default=-1)
    _add_mapper_arg(p)
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--strict", action="store_true", help="exit 1 unless the photos reconstruct (DESIGN.md)")
    p.add_argument("-q", "--quiet", action="store_true")
    p.add_argument("-v", "--verbose", action="store_true")
    p.set_defaults(func=cmd_check)

    for name, helptext in (("report", "write the HTML flight report (and/or PNG figures) of a route"),
                           ("plot", "write PNG figures (and/or the HTML report) of a route")):
        p = sub.add_parser(name, help=helptext)
        p.add_argument("route", metavar="ROUTE.json")
        _add_scene_args(p, targets_positional=False)
        p.add_argument("--spacing", type=float, default=None, metavar="M")
        p.add_argument("--simulation", default=None, metavar="SIMULATION.json",
                       help="show what 'coverplan simulate' recovered (its DIR/simulation.json)")
        if name == "report":
            p.add_argument("-o", "--output", dest="report", default=None, metavar="REPORT.html")
            p.add_argument("--plot", default=None, metavar="PREFIX")
        else:
            p.add_argument("-o", "--output", dest="plot", default=None, metavar="PREFIX")
            p.add_argument("--report", default=None, metavar="REPORT.html")
        p.add_argument("-q", "--quiet", action="store_true")
        p.add_argument("-v", "--verbose", action="store_true")
        p.set_defaults(func=cmd_report)

    p = sub.add_parser("export", help="write a route for autopilots: QGC .plan, WPL, Litchi, DJI WPML, KML, GeoJSON, CSV")
    p.add_argument("route", metavar="ROUTE.json")
    p.add_argument("--format", required=True, metavar="FORMATS",
                   help="comma separated: qgc,wpl,litchi,wpml,kml,geojson,csv")
    p.add_argument("-o", "--output", default=None, metavar="PREFIX", help="default: the route path without .json")
    p.add_argument("--crs", default=None, metavar="EPSG:XXXX", help="the CRS of a route that has none")
    p.add_argument("--geo-origin", nargs=3, type=float, default=None, metavar=("LAT", "LON", "H"))
    p.add_argument("--drone", default=None, metavar="NAME", help="for WPML: the drone (default: the route's)")
    _add_export_args(p)
    p.add_argument("--speed", type=float, default=None, metavar="M_PER_S")
    p.set_defaults(func=cmd_export)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except CoverplanError as exc:
        print(f"coverplan: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("coverplan: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into a reader that stopped early (| head)
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
