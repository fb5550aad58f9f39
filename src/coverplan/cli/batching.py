"""`coverplan batch`: every chosen building of a city model, on Dask."""

from __future__ import annotations

from coverplan.batch.run import BatchSettings, run_batch
from coverplan.batch.selecting import parse_where
from coverplan.cli.args import camera_from_args, export_options, plan_options
from coverplan.cli.flags import add_planning_args
from coverplan.errors import ParameterError
from coverplan.io import parse_formats
from coverplan.progress import Progress


def cmd_batch(args) -> int:

    """Run ``coverplan batch``: plan many buildings of a city model on Dask.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        1 when a building failed, else 0.
    """
    if args.workers is not None and args.workers < 1:
        raise ParameterError(f"--workers must be at least 1, got {args.workers}")
    if args.workers is not None and args.scheduler:
        raise ParameterError("give either --workers (a local cluster) or --scheduler (a running one), not both")
    if args.merge_obstacles_within is not None and args.merge_obstacles_within < 0:
        raise ParameterError(f"--merge-obstacles-within must be >= 0, got {args.merge_obstacles_within}")
    if args.buildings and (args.all or args.bbox or args.where):
        raise ParameterError("--buildings names the buildings; it does not combine with --all, --bbox or --where")
    formats = parse_formats(args.export)
    settings = BatchSettings(camera=camera_from_args(args), plan_options=plan_options(args, formats), exports=formats,
                             export_options=export_options(args), report=args.report,
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


def register(sub) -> None:
    """Add the subcommand to ``sub`` (argparse subparsers).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommands.
    """
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
    add_planning_args(p)
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
