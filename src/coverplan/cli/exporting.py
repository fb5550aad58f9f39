"""`coverplan export`: a route for autopilots and apps."""

from __future__ import annotations

import sys

from coverplan.cli.args import export_options
from coverplan.cli.flags import add_export_args
from coverplan.errors import ParameterError
from coverplan.flight.route import Route
from coverplan.geometry.geo import check_crs
from coverplan.io import export_route, parse_formats
from coverplan.io.load import _check_geodetic_origin


def cmd_export(args) -> int:
    """Run ``coverplan export``: write a route file in flight-app formats.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        0.
    """
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
    refused: list = []
    written = export_route(route, stem, formats, refused=refused, **export_options(args))
    if not written:
        raise ParameterError("no format could be written: " + "; ".join(f"{n}: {w}" for n, w in refused))
    for name, why in refused:
        print(f"coverplan: not written as {name}: {why}", file=sys.stderr)
    print("written: " + ", ".join(str(p) for p in written))
    return 0


def register(sub) -> None:
    """Add the subcommand to ``sub`` (argparse subparsers).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommands.
    """
    p = sub.add_parser("export", help="write a route for autopilots: QGC .plan, WPL, Litchi, DJI WPML, KML, GeoJSON, CSV")
    p.add_argument("route", metavar="ROUTE.json", help="a route written by coverplan plan")
    p.add_argument("--format", required=True, metavar="FORMATS",
                   help="comma separated: qgc,wpl,litchi,wpml,kml,geojson,csv")
    p.add_argument("-o", "--output", default=None, metavar="PREFIX", help="default: the route path without .json")
    p.add_argument("--crs", default=None, metavar="EPSG:XXXX", help="the CRS of a route that has none")
    p.add_argument("--geo-origin", nargs=3, type=float, default=None, metavar=("LAT", "LON", "H"),
                   help="of a route that has no georeference: the WGS84 position of its frame's origin")
    p.add_argument("--drone", default=None, metavar="NAME", help="for WPML: the drone (default: the route's)")
    add_export_args(p)
    p.add_argument("--speed", type=float, default=None, metavar="M_PER_S",
                   help="cruise speed written into the missions (default: the drone's, else 5)")
    p.set_defaults(func=cmd_export)
