"""`coverplan evaluate`: a route's or another app's mission's coverage and safety."""

from __future__ import annotations

import sys

from coverplan.cli.args import flight_paths, flights_and_scene
from coverplan.cli.flags import (
    FLIGHTS_HELP,
    ROUTE_CEILING,
    add_mission_args,
    add_scene_args,
    add_zone_args,
    parse_ceiling,
)
from coverplan.equipment.camera import check_positive
from coverplan.evaluation import evaluate
from coverplan.files import json_text
from coverplan.io.zones import read_zones
from coverplan.progress import Progress


def cmd_evaluate(args) -> int:
    """Run ``coverplan evaluate``: judge a route or mission with the independent evaluator.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        1 under ``--strict`` when the route fails a rule, else 0.
    """
    if args.spacing is not None:
        check_positive("--spacing", args.spacing)
    route, scene = flights_and_scene(args)
    if len(flight_paths(args.route)) > 1:
        print(f"coverplan: {route.n_flights} flights judged together, in the order given", file=sys.stderr)
    if args.max_altitude is not ROUTE_CEILING:  # judged against a ceiling given here instead of the route's own
        route.params["max_altitude_m"] = args.max_altitude
    if args.keep_out or args.keep_in:  # judged against these zones instead of the route's own
        route.params["zones"] = read_zones(args.keep_out, args.keep_in, scene).to_list()
    progress = Progress(bars=not args.json)
    with progress.stage("evaluate", total=len(route.shots), unit="shot") as update:
        ev = evaluate(route, scene, spacing=args.spacing, progress=update)
    if args.json:
        print(json_text(ev.metrics))
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


def register(sub) -> None:
    """Add the subcommand to ``sub`` (argparse subparsers).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommands.
    """
    p = sub.add_parser("evaluate", help="check a route's or another app's mission's coverage and safety")
    p.add_argument("route", nargs="+", metavar="ROUTE", help=FLIGHTS_HELP)
    add_scene_args(p, targets_positional=False, recorded=True)
    add_mission_args(p)
    p.add_argument("--spacing", type=float, default=None, metavar="M",
                   help="surface sample spacing in metres (default 0.25, with a seed the planner does not use)")
    p.add_argument("--max-altitude", type=parse_ceiling, default=ROUTE_CEILING, metavar="M|none",
                   help="judge against this altitude ceiling above the ground (default: the route's own; "
                        "missions from other apps: none)")
    add_zone_args(p, judged=True)
    p.add_argument("--json", action="store_true", help="print the metrics as JSON")
    p.add_argument("--strict", action="store_true",
                   help="exit 1 when the route is unsafe or coverage is below --min-coverage")
    p.add_argument("--min-coverage", type=float, default=None, metavar="PCT",
                   help="with --strict: the least coverage in percent that passes (default: none asked)")
    p.set_defaults(func=cmd_evaluate)
