"""`coverplan check`: a flight's real photos reconstructed, and what they miss."""

from __future__ import annotations

import sys

from coverplan.cli.args import scene_from_args
from coverplan.cli.flags import add_mapper_arg, add_scene_args
from coverplan.equipment.camera import check_positive
from coverplan.errors import ParameterError
from coverplan.evaluation import evaluate
from coverplan.files import json_text
from coverplan.job import write_pictures
from coverplan.progress import Progress
from coverplan.sfm.cameras import LENS_MODEL, LENS_MODELS
from coverplan.sfm.check import WORKING_PX
from coverplan.sfm.check import check as check_photos
from coverplan.sfm.colmap import SPATIAL_NEIGHBOURS


def cmd_check(args) -> int:
    """Run ``coverplan check``: reconstruct a flight's real photos and judge them.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        1 under ``--strict`` when the photos would not reconstruct, else 0.
    """
    from pathlib import Path

    gsd, security = check_positive("--gsd", args.gsd), check_positive("--security", args.security)
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise ParameterError(f"{out} exists and is not a folder")
    scene = scene_from_args(args)
    progress = Progress(bars=not args.quiet, verbose=args.verbose)
    result = check_photos(args.photos, scene, out, gsd=gsd, security=security, threads=args.threads, fit=args.fit,
                          mapper=args.mapper, working_px=args.working_px or None, lens_model=args.lens_model,
                          spatial_neighbours=int(check_positive("--neighbours", args.neighbours)), progress=progress)
    for name, why in result.left_out:
        print(f"coverplan: {name} left out: {why}", file=sys.stderr)
    if args.report:
        with progress.stage("evaluate"):
            ev = evaluate(result.route, scene)
        write_pictures(result.route, scene, ev, args.report, None, progress, check=result,
                       title=f"coverplan check: {Path(args.photos).name}")
    if args.json:
        print(json_text(result.to_dict()))
    elif not args.quiet:
        print(result.table())
        print(f"written: {out / 'check.json'}, {out / 'missing.ply'}, {out / 'missing.geojson'}"
              + (f", {args.report}" if args.report else ""))
    return 1 if args.strict and not result.reconstructable else 0


def register(sub) -> None:
    """Add the subcommand to ``sub`` (argparse subparsers).

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subcommands.
    """
    p = sub.add_parser("check", help="reconstruct a flight's real photos (EXIF/XMP positions) and say what is missing")
    p.add_argument("photos", metavar="PHOTOS_DIR", help="folder of the flight's photos (JPEG with GNSS tags)")
    add_scene_args(p, targets_positional=False)
    p.add_argument("-o", "--output", required=True, metavar="DIR",
                   help="folder for COLMAP files, check.json, missing.ply and missing.geojson")
    p.add_argument("--gsd", type=float, default=0.01, metavar="M_PER_PX",
                   help="the GSD to judge the photos' flight by in its report (default 0.01)")
    p.add_argument("--security", type=float, default=3.0, metavar="M",
                   help="the security distance to judge it by in its report (default 3)")
    p.add_argument("--report", default=None, metavar="REPORT.html", help="also write the HTML report of the flight")
    p.add_argument("--no-fit", dest="fit", action="store_false",
                   help="judge the model as aligned through the GNSS tags, without fitting it to the scene")
    p.add_argument("--threads", type=int, default=-1, metavar="N", help="threads for SfM (default: all cores)")
    p.add_argument("--working-px", type=int, default=WORKING_PX, metavar="PX",
                   help=f"find features on the photos scaled down to this longest side (default {WORKING_PX}; "
                        "0: full size)")
    p.add_argument("--lens-model", choices=tuple(LENS_MODELS), default=LENS_MODEL,
                   help="the distortion COLMAP estimates for photos without DJI DewarpData: one radial term "
                        f"(simple_radial), two (radial) or two radial and two tangential (opencv); default {LENS_MODEL}")
    p.add_argument("--neighbours", type=int, default=SPATIAL_NEIGHBOURS, metavar="N",
                   help=f"spatial matching: each photo is matched with its N nearest by the GNSS tags (default "
                        f"{SPATIAL_NEIGHBOURS}; 20 halves the matching of a 1,000-photo flight)")
    add_mapper_arg(p)
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.add_argument("--strict", action="store_true",
                   help="exit 1 unless the photos reconstruct into one model that covers the target")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars or table")
    p.add_argument("-v", "--verbose", action="store_true", help="log each stage's time")
    p.set_defaults(func=cmd_check)
