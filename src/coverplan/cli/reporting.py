"""`coverplan report` and `coverplan plot`: the HTML report and PNG figures of a route."""

from __future__ import annotations

from coverplan.cli.args import flights_and_scene
from coverplan.cli.flags import FLIGHTS_HELP, add_mission_args, add_scene_args
from coverplan.errors import ParameterError
from coverplan.evaluation import evaluate
from coverplan.job import write_pictures
from coverplan.progress import Progress
from coverplan.sfm.simulation import Simulation


def cmd_report(args) -> int:
    """Run ``coverplan report``: write the HTML report and figures of a route.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0.
    """
    if not args.report and not args.plot:
        raise ParameterError("give -o REPORT.html and/or --plot PREFIX")
    route, scene = flights_and_scene(args)
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


def register(sub) -> None:
    """Add the subcommand to ``sub`` (argparse subparsers).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommands.
    """
    for name, helptext in (("report", "write the HTML flight report (and/or PNG figures) of a route"),
                           ("plot", "write PNG figures (and/or the HTML report) of a route")):
        p = sub.add_parser(name, help=helptext)
        p.add_argument("route", nargs="+", metavar="ROUTE", help=FLIGHTS_HELP)
        add_scene_args(p, targets_positional=False, recorded=True)
        add_mission_args(p)
        p.add_argument("--spacing", type=float, default=None, metavar="M",
                       help="surface sample spacing in metres (default 0.25)")
        p.add_argument("--simulation", default=None, metavar="SIMULATION.json",
                       help="show what 'coverplan simulate' recovered (its DIR/simulation.json)")
        if name == "report":
            p.add_argument("-o", "--output", dest="report", default=None, metavar="REPORT.html", help="the HTML report")
            p.add_argument("--plot", default=None, metavar="PREFIX", help="also PNG figures PREFIX_*.png")
        else:
            p.add_argument("-o", "--output", dest="plot", default=None, metavar="PREFIX",
                           help="PNG figures PREFIX_*.png")
            p.add_argument("--report", default=None, metavar="REPORT.html", help="also the HTML report")
        p.add_argument("-q", "--quiet", action="store_true", help="no progress bars or table")
        p.add_argument("-v", "--verbose", action="store_true", help="log each stage's time")
        p.set_defaults(func=cmd_report)
