"""`coverplan plan`: a safe flight covering the target, its summary, exports and report."""

from __future__ import annotations

import sys

from coverplan.cli.args import camera_from_args, drone_from_args, export_options, plan_options, scene_from_args
from coverplan.cli.flags import add_planning_args, add_scene_args
from coverplan.cli.simulating import simulate_defaults, simulate_route
from coverplan.cli.summary import plan_summary
from coverplan.equipment.drones import security_shortfall
from coverplan.errors import ParameterError
from coverplan.flight.start import start_from_latlon
from coverplan.io import GEOGRAPHIC_FORMATS, parse_formats
from coverplan.job import run_job, write_pictures
from coverplan.progress import Progress
from coverplan.sfm.existing import read_existing
from coverplan.sfm.simulation import Simulation
from coverplan.world.merge import merge_into_target


def cmd_plan(args) -> int:
    """Run ``coverplan plan``: plan, evaluate, save, report and export a flight.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit status.
    """
    from pathlib import Path


    out = Path(args.output)
    camera = camera_from_args(args)
    formats = parse_formats(args.export)
    progress = Progress(bars=not args.quiet, verbose=args.verbose)
    with progress.stage("load scene"):
        scene = scene_from_args(args)
        if args.merge_obstacles_within is not None:
            if args.merge_obstacles_within < 0:
                raise ParameterError(f"--merge-obstacles-within must be >= 0, got {args.merge_obstacles_within}")
            scene = merge_into_target(scene, args.merge_obstacles_within)
    # the inputs are told first, then where the route goes
    if out.exists() and not args.force:
        raise ParameterError(f"{out} exists; pass --force to overwrite it")
    if not out.parent.exists():
        raise ParameterError(f"{out.parent} does not exist (output folder for {out.name})")
    for note in scene.notes:  # say it now, before the long work, not only in the summary
        if note.startswith("WARNING"):
            print(f"coverplan: {note}", file=sys.stderr)
    if set(formats) & GEOGRAPHIC_FORMATS and not (scene.crs or scene.geodetic_origin):
        raise ParameterError(f"{', '.join(sorted(set(formats) & GEOGRAPHIC_FORMATS))} export needs a georeference: "
                             "the input has no CRS; pass --crs EPSG:XXXX or --geo-origin LAT LON H")
    if args.strict:
        shortfall = security_shortfall(args.security, drone_from_args(args))
        if shortfall:
            raise ParameterError(f"{shortfall} (--strict)")
    # --start is in the input models' coordinates, like the meshes: move it with them.
    start = None if args.start is None else scene.to_local(args.start)
    if args.start_latlon is not None:
        if start is not None:
            raise ParameterError("give --start or --start-latlon, not both")
        start = start_from_latlon(scene, args.start_latlon)
    options = plan_options(args, formats)
    options["force"] = args.force
    if args.existing:
        with progress.stage("existing photos"):
            options["existing"] = read_existing(args.existing, scene, camera, args.gsd, args.security, progress)
    job = run_job(scene, camera, out, formats=formats, export_options=export_options(args), evaluated=args.evaluate,
                  report=args.report, plot=args.plot, start=start, progress=progress, **options)
    route, ev, written = job.route, job.evaluation, job.written
    if job.exports_withheld:
        print("coverplan: the evaluator found the route unsafe; no mission was exported", file=sys.stderr)
    if not args.quiet:
        print(plan_summary(route, verbose=args.verbose))
        print("written: " + ", ".join(str(p) for p in written))
    if args.simulate:
        code = simulate_route(route, scene, args.simulate, simulate_defaults(args))
        if args.report:
            write_pictures(route, scene, ev, args.report, args.plot, progress,
                           Simulation.load(Path(args.simulate) / "simulation.json"))
        return code
    return 0


def register(sub) -> None:
    """Add the subcommand to ``sub`` (argparse subparsers).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommands.
    """
    p = sub.add_parser("plan", help="plan a safe flight covering the target surface",
                       usage="coverplan plan TARGET [TARGET ...] (--drone NAME | --camera PRESET | --sensor-mm W H "
                             "--focal-mm F --image-px W H) --gsd M_PER_PX --security M -o ROUTE.json [options]",
                       description="Plan a safe photo flight whose photos rebuild the target surface. The options "
                                   "are grouped as a survey is set up; the advanced ones keep their tested defaults.")
    groups = add_planning_args(p)
    add_scene_args(groups["scene"], targets_positional=True)
    flight, safety, outputs, advanced = (groups[k] for k in ("flight", "safety", "exports", "advanced"))
    flight.add_argument("--start", nargs=3, type=float, default=None, metavar=("X", "Y", "Z"),
                        help="take-off and landing point, in the input models' coordinates (default: just outside "
                             "the shot region, north-west; the summary prints it)")
    latlon = flight.add_argument("--start-latlon", nargs="+", type=float, default=None, metavar="DEG",
                        help="or: the take-off point in WGS84 degrees, optionally with a third value, its height "
                             "above the ground in m (default 0; raised to the lowest flight height); needs a "
                             "georeferenced scene")
    latlon.shown_as = "LAT LON [H]"
    flight.add_argument("--existing", default=None, metavar="PHOTOS_DIR|MISSION",
                        help="photos already taken (a folder of photos with GPS tags, a route .json, or a mission: "
                             "QGC .plan, .waypoints, Litchi .csv, DJI .kmz): their views count and the new flight "
                             "takes only what they do not give")
    outputs.add_argument("-o", "--output", required=True, metavar="ROUTE.json",
                         help="the route file to write (exports, report and figures are named after it)")
    outputs.add_argument("--report", default=None, metavar="REPORT.html", help="also write the HTML flight report")
    outputs.add_argument("--plot", default=None, metavar="PREFIX", help="also write PNG figures PREFIX_*.png")
    outputs.add_argument("--simulate", default=None, metavar="DIR",
                         help="also render the photos and reconstruct them with COLMAP into DIR, with simulate's "
                              "defaults (needs coverplan[sfm]; 'coverplan simulate ROUTE.json' takes its options)")
    safety.add_argument("--force", action="store_true",
                        help="overwrite an existing output file, and plan a GSD, security distance, altitude or "
                             "flight time that looks like a unit slip (refused without it)")
    safety.add_argument("--strict", action="store_true",
                        help="refuse a security distance below the drone's position error bound plus 1 m; "
                             "with --simulate, exit 1 unless the photos reconstruct")
    advanced.add_argument("--no-evaluate", dest="evaluate", action="store_false",
                          help="skip the independent evaluation of the planned route")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars or summary")
    p.add_argument("-v", "--verbose", action="store_true",
                   help="the planner's internals in the summary, and each stage's time")
    p.set_defaults(func=cmd_plan)
