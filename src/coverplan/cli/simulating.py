"""`coverplan simulate`: render a route's photos, reconstruct them with COLMAP, judge the result."""

from __future__ import annotations

import argparse
import sys

from coverplan.cli.args import scene_for_route
from coverplan.cli.flags import add_scene_args, add_simulate_args
from coverplan.equipment.camera import check_positive
from coverplan.errors import ParameterError
from coverplan.files import json_text
from coverplan.flight.route import Route
from coverplan.progress import Progress
from coverplan.sfm.simulate import simulate


def cmd_simulate(args) -> int:
    """Run ``coverplan simulate``: render a route's photos under field conditions and reconstruct them.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        1 under ``--strict`` when the flight would not reconstruct, else 0.
    """
    apply_quick(args)
    route = Route.load(args.route)
    scene = scene_for_route(args, route)
    return simulate_route(route, scene, args.output, args)


QUICK = {"draws": 1, "photo_width": 640, "max_features": 4096, "neighbours": 20}


def apply_quick(args) -> None:
    """``--quick``: the options left at their defaults take the quick preset's values (one draw
    of 640 px photos with 4,096 features each, 20 spatial neighbours).

    Parameters
    ----------
    args : argparse.Namespace
        Changed in place.
    """
    if not getattr(args, "quick", False):
        return
    defaults = simulate_defaults(argparse.Namespace())
    for name, value in QUICK.items():
        if getattr(args, name) == getattr(defaults, name):
            setattr(args, name, value)


def time_told(route, args, width: int) -> str:
    """The line told before the work starts: photos, draws and the estimated time.

    Parameters
    ----------
    route : Route
        The route.
    args : argparse.Namespace
        The parsed command line.
    width : int
        Photo width, px.

    Returns
    -------
    str
        The line.
    """
    from coverplan.progress import format_duration
    from coverplan.sfm.estimate import simulate_seconds

    photos = int(route.with_existing_photos().shot.sum())
    draws = 1 if args.conditions == "ideal" else args.draws
    seconds = simulate_seconds(photos, draws=draws, width=width, max_features=args.max_features,
                               neighbours=args.neighbours, mapper=args.mapper, threads=args.threads)
    return (f"simulating {photos} photos, {draws} draw{'s' if draws > 1 else ''} of {width} px: about "
            f"{format_duration(seconds)} on this machine" + (" (--quick: a first look; the proof is the default "
                                                            "three draws at 1024 px)" if getattr(args, "quick", False)
                                                            else ""))


def simulate_defaults(args):
    """``plan --simulate``'s options: simulate's defaults, with plan's --quiet, --verbose and --strict.

    Parameters
    ----------
    args : argparse.Namespace
        ``plan``'s parsed command line.

    Returns
    -------
    argparse.Namespace
        ``simulate``'s options.
    """
    parser = argparse.ArgumentParser()
    add_simulate_args(parser)
    ns = parser.parse_args([])
    for name in ("quiet", "verbose", "strict"):
        setattr(ns, name, getattr(args, name, False))
    return ns


def simulate_route(route, scene, out_dir, args) -> int:
    """Render, reconstruct and judge; prints the table (or JSON), exit 1 under --strict when
    the flight would not reconstruct.

    Parameters
    ----------
    route : Route
        The route.
    scene : Scene
        Its scene.
    out_dir : str or Path
        Where the photos and models go.
    args : argparse.Namespace
        ``simulate``'s options.

    Returns
    -------
    int
        The exit status.
    """
    from pathlib import Path


    width = int(check_positive("--photo-width", args.photo_width))
    if width < 160:
        raise ParameterError(f"--photo-width must be at least 160 px, got {width}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ParameterError(f"{out} exists and is not a folder")
    quiet = getattr(args, "quiet", False)
    progress = Progress(bars=not quiet, verbose=getattr(args, "verbose", False), lines=True)
    if args.draws < 1:
        raise ParameterError(f"--draws must be at least 1, got {args.draws}")
    sim = simulate(route, scene, out, conditions=args.conditions, draws=args.draws, texture=args.texture,
                   matching=args.matching, mapper=args.mapper, spatial_neighbours=args.neighbours,
                   max_features=args.max_features, width=width, threads=args.threads, progress=progress,
                   lens=getattr(args, "lens", "pinhole"), announce=None if quiet else
                   lambda: print(f"coverplan: {time_told(route, args, width)}", file=sys.stderr, flush=True))
    sim.save(out / "simulation.json")
    if getattr(args, "json", False):
        print(json_text(sim.to_dict()))
    elif not getattr(args, "quiet", False):
        print(sim.table())
        print(f"written: {out / 'simulation.json'}, photos in {out / 'images'}")
    if getattr(args, "strict", False) and not sim.reconstructable:
        print("coverplan: strict check failed: the photos do not reconstruct (see the table)", file=sys.stderr)
        return 1
    return 0


def register(sub) -> None:
    """Add the subcommand to ``sub`` (argparse subparsers).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommands.
    """
    p = sub.add_parser("simulate", help="render a route's photos, reconstruct them with COLMAP, judge the result")
    p.add_argument("route", metavar="ROUTE.json", help="a route written by coverplan plan")
    add_scene_args(p, targets_positional=False, recorded=True)
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="folder for photos, COLMAP files and simulation.json")
    add_simulate_args(p)
    p.add_argument("--quick", action="store_true",
                   help="a first look in minutes: one draw of 640 px photos, 4,096 features each, 20 spatial "
                        "neighbours (options given alongside still count); it gives up the worst of three draws "
                        "and the detail of 1024 px photos, so its verdict is not the proof")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--strict", action="store_true",
                   help="exit 1 unless the flight is reconstructable (one model with >= 98 %% of the photos and "
                        ">= 95 %% of the surface; docs/design.md)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars or table")
    p.add_argument("-v", "--verbose", action="store_true", help="log each stage's time")
    p.set_defaults(func=cmd_simulate)
