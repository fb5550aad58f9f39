"""The command line read: its parser, and the scene, camera, drone, flights and options the flags give."""

from __future__ import annotations

import argparse
import sys

from coverplan.equipment.camera import PRESETS, Camera, check_positive, get_camera
from coverplan.equipment.drones import get_drone
from coverplan.equipment.flighttime import FlightModel
from coverplan.errors import ParameterError
from coverplan.flight.missions import mission_to_route
from coverplan.flight.route import Route
from coverplan.io import read_mission
from coverplan.io.load import load_scene
from coverplan.io.qgc import PX4_MISSION_ITEMS
from coverplan.shots.reconstructability import MatchRule
from coverplan.world.pointcloud import parse_classes


class Formatter(argparse.HelpFormatter):
    """argparse's help, where an option may show its values as it takes them (``shown_as``:
    "LAT LON [H]" for two or three numbers, which ``nargs`` cannot say).

    Parameters
    ----------
    prog : str
        The program's name.
    indent_increment : int
        Spaces per nesting level.
    max_help_position : int
        The column help text starts at.
    width : int, optional
        The help's width; the terminal's when None.
    """

    def _format_args(self, action, default_metavar):
        return getattr(action, "shown_as", None) or super()._format_args(action, default_metavar)


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors and exit status 2.

    Parameters
    ----------
    *args, **kwargs
        ``argparse.ArgumentParser``'s arguments.
    """

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", Formatter)
        super().__init__(*args, **kwargs)

    def error(self, message):
        """Print the usage's first line and ``message`` as one line, and exit with status 2.

        Parameters
        ----------
        message : str
            What is wrong.
        """
        sys.stderr.write(f"{self.prog}: error: {message} (see {self.prog} --help)\n")
        sys.exit(2)


def scene_from_args(args):
    """The scene the command line's scene options name (``load_scene``).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    Scene
        The scene.
    """
    return load_scene(args.targets, args.obstacles, units=args.units, ground=args.ground,
                      target_names=args.target_names, up_axis=args.up_axis, building=args.building,
                      lod=args.lod, context_radius=args.context_radius, crs=args.crs,
                      geodetic_origin=args.geo_origin, obstacle_points=args.obstacle_points,
                      points_resolution=args.points_resolution, point_classes=parse_classes(args.point_classes),
                      height_attribute=args.height_attribute, height=args.height, roof_attribute=args.roof_attribute,
                      terrain=args.terrain)


SCENE_OPTIONS = ("obstacles", "units", "ground", "terrain", "target_names", "up_axis", "building", "lod",
                 "context_radius", "crs", "geo_origin", "height_attribute", "height", "roof_attribute",
                 "obstacle_points", "point_classes")


def scene_for_route(args, route=None, path=None):
    """The scene given with --target, else the one the route file ``path`` (default
    ``args.route``) records (``route``: that file, loaded; None: a mission from another app,
    which records none).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    route : Route, optional
        The route file, loaded.
    path : str or Path, optional
        The route file.

    Returns
    -------
    Scene
        The scene.

    Raises
    ------
    ParameterError
        When neither ``--target`` nor the route gives a scene.
    """
    path = args.route if path is None else path
    if args.targets:
        return scene_from_args(args)
    given = [name for name in SCENE_OPTIONS if getattr(args, name, None) not in (None, [])]
    if given:
        raise ParameterError(f"--{given[0].replace('_', '-')} needs --target: give the whole scene, or none of it "
                             "to use the one the route records")
    record = None if route is None else route.params.get("scene")
    if not record:
        what = "records no scene (planned from a mesh in memory, or by an older coverplan)" if route is not None \
            else "is a mission from another app"
        raise ParameterError(f"{path} {what}: give the scene with --target")
    from coverplan.io.load import scene_from_record
    return scene_from_record(record, path)


def flight_paths(given: list[str]) -> list[str]:
    """The flight files named, with each pattern (``*.kmz``, ``house.f?.plan``) expanded, in
    natural order (f2 before f10).

    Parameters
    ----------
    given : list of str
        Paths and patterns.

    Returns
    -------
    list of str
        Paths.

    Raises
    ------
    ParameterError
        When a pattern matches no file.
    """
    import glob
    import re
    from pathlib import Path

    def natural(name):
        return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", name)]

    out = []
    for item in given:
        if glob.has_magic(item) and not Path(item).exists():
            found = sorted(glob.glob(item), key=natural)
            if not found:
                raise ParameterError(f"{item}: matches no file")
            out += found
        else:
            out.append(item)
    return out


def flights_and_scene(args):
    """The route ``args.route`` names (route files and missions from other apps, one or several:
    battery flights judged together) and its scene: ``--target``, else the first route file's.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    route : Route
        The flights joined.
    scene : Scene
        Their scene.
    """
    from coverplan.flight.joining import join_flights

    paths = flight_paths(args.route)
    plans = [p for p in paths if p.lower().endswith(".json")]
    if plans and len(plans) == len(paths) and (args.gsd is not None or args.security is not None):
        raise ParameterError("a route file carries its own camera, GSD and security distance; "
                             "--camera/--gsd/--security are for missions from other apps")
    loaded = {p: Route.load(p) for p in plans}
    scene = scene_for_route(args, loaded[plans[0]], plans[0]) if plans else scene_for_route(args, None, paths[0])
    routes = [loaded[p] if p in loaded else mission_route(args, scene, p) for p in paths]
    return join_flights(routes, paths), scene


def camera_from_args(args) -> Camera:
    """The camera the command line names: ``--drone``'s, a preset, or one given by sensor, focal length and image size.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    Camera
        The camera.

    Raises
    ------
    ParameterError
        When no camera is given, a custom one only in part, two at once, or one beside ``--drone``.
    """
    drone = drone_from_args(args)
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


def drone_from_args(args):
    """The drone profile ``--drone`` names, or None.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    DroneProfile or None
        The profile.
    """
    name = getattr(args, "drone", None)
    return get_drone(name) if name else None


def flight_model_from_args(args):
    """The flight-time model: the drone's (at --speed if given), else generic at --speed.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    FlightModel
        The model.
    """
    drone = drone_from_args(args)
    speed = None if args.speed is None else check_positive("--speed", args.speed)
    model = drone.flight_model(speed) if drone is not None else FlightModel(cruise_speed=speed or 5.0)
    if getattr(args, "shot_seconds", None) is not None:  # export has no photos to time
        from dataclasses import replace
        if not args.shot_seconds >= 0:
            raise ParameterError(f"--shot-seconds must be >= 0, got {args.shot_seconds}")
        model = replace(model, photo_seconds=float(args.shot_seconds))
    return model


def export_options(args) -> dict:
    """The writers' keyword arguments from the export flags.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    dict
        ``firmware``, ``speed``, ``drone`` and ``wpml_heights``.
    """
    return {"firmware": args.firmware, "speed": flight_model_from_args(args).cruise_speed, "drone": drone_from_args(args),
            "wpml_heights": args.wpml_heights}


def mission_route(args, scene, path=None):
    """A QGroundControl / Mission Planner / Litchi / WPML mission (``path``, default
    ``args.route``) as a route in the scene's frame.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line (camera, GSD, security).
    scene : Scene
        The scene.
    path : str or Path, optional
        The mission file.

    Returns
    -------
    Route
        The mission as a route.
    """
    path = args.route if path is None else path
    missing = [flag for flag, v in (("--gsd", args.gsd), ("--security", args.security)) if v is None]
    if missing or not (args.camera or args.sensor_mm):
        need = missing + ([] if (args.camera or args.sensor_mm) else ["--camera"])
        raise ParameterError(f"{path} is a mission from another app: give {', '.join(need)} "
                             "(the camera it flies, the GSD and security distance to judge it by)")
    route = mission_to_route(read_mission(path), scene, camera_from_args(args), check_positive("--gsd", args.gsd),
                             check_positive("--security", args.security))
    for note in route.extra["notes"]:  # what the file left open, and how it was read
        print(f"coverplan: {note}", file=sys.stderr)
    return route


def plan_options(args, formats: list[str]) -> dict:
    """planner.plan's keyword arguments from the planning flags ``plan`` and ``batch`` share;
    ``formats``: the exports asked (``parse_formats(args.export)``).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    formats : list of str
        The exports asked.

    Returns
    -------
    dict
        ``plan``'s keyword arguments.
    """
    items = args.max_mission_items
    if items is None and "qgc" in formats and args.firmware == "px4":
        items = PX4_MISSION_ITEMS  # a longer flight would be refused at export
    return dict(gsd=args.gsd, security=args.security, min_views=args.min_views,
                min_triangulation_deg=args.min_triangulation_deg, rule=args.rule, match=match_rule_from_args(args),
                max_incidence_deg=args.max_incidence_deg, min_altitude=args.min_altitude, max_altitude=args.max_altitude,
                spacing=args.spacing,
                gimbal_pitch_range_deg=gimbal_from_args(args), drone=drone_from_args(args), flight_model=flight_model_from_args(args),
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


def gimbal_from_args(args):
    """The gimbal range given on the command line (None: the drone's, or -90..30).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    (float, float) or None
        Lowest and highest pitch.
    """
    if args.gimbal_min_deg is None and args.gimbal_max_deg is None:
        return None
    drone = drone_from_args(args)
    lo, hi = drone.gimbal_pitch_deg if drone is not None else (-90.0, 30.0)
    return (lo if args.gimbal_min_deg is None else args.gimbal_min_deg,
            hi if args.gimbal_max_deg is None else args.gimbal_max_deg)


def match_rule_from_args(args):
    """The sfm rule's settings from the command line (None: the defaults).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    MatchRule or None
        The rule.
    """

    given = {k: v for k, v in (("max_pair_deg", args.max_pair_deg), ("min_overlap", args.min_overlap),
                               ("min_neighbours", args.min_neighbours), ("sharp_views", args.sharp_views),
                               ("framed_views", args.framed_views), ("link_test", args.link_test),
                               ("braced", None if args.links is None else args.links == "braced"),
                               ("min_cut", args.min_cut))
             if v is not None}
    if not given:
        return None
    if args.rule != "sfm":
        flag = {"braced": "links"}.get(next(iter(given)), next(iter(given)))
        raise ParameterError(f"--{flag.replace('_', '-')} belongs to --rule sfm")
    return MatchRule(**given)
