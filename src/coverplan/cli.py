"""Command line: argument parsing and error reporting only; the work is in the modules."""

from __future__ import annotations

import argparse
import json
import sys

from . import __version__
from .camera import PRESETS, Camera, check_positive, get_camera
from .errors import CoverplanError, ParameterError


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
    p.add_argument("--units", default="m", choices=["m", "cm", "mm", "ft", "in"],
                   help="units of the mesh files (default m)")
    p.add_argument("--ground", type=float, default=None, metavar="Z",
                   help="ground height in metres (default: lowest point of the target)")
    p.add_argument("--target-names", nargs="+", default=None, metavar="NAME",
                   help="in multi-object target files, the objects that are targets (others are obstacles)")
    p.add_argument("--up-axis", choices=["y", "z"], default=None,
                   help="up axis of the mesh files (default z; glTF/GLB default y)")


def _scene(args):
    from .scene import load_scene
    return load_scene(args.targets, args.obstacles, units=args.units, ground=args.ground,
                      target_names=args.target_names, up_axis=args.up_axis)


def _camera(args) -> Camera:
    if args.camera and any(v is not None for v in (args.sensor_mm, args.focal_mm, args.image_px)):
        raise ParameterError("give either --camera or --sensor-mm/--focal-mm/--image-px, not both")
    if args.camera:
        return get_camera(args.camera)
    if args.sensor_mm is None or args.focal_mm is None or args.image_px is None:
        raise ParameterError("give a camera: --camera PRESET, or all of --sensor-mm W H --focal-mm F "
                             f"--image-px W H (presets: {', '.join(sorted(PRESETS))})")
    return Camera(args.sensor_mm[0], args.sensor_mm[1], args.focal_mm, args.image_px[0], args.image_px[1])


def cmd_cameras(args) -> int:
    print(f"{'name':<15}{'sensor mm':>14}{'focal mm':>10}{'image px':>13}{'HFOV':>8}{'VFOV':>8}")
    for name, cam in sorted(PRESETS.items()):
        print(f"{name:<15}{cam.sensor_width_mm:>7.2f} x{cam.sensor_height_mm:>5.2f}{cam.focal_length_mm:>10.2f}"
              f"{cam.image_width_px:>7d}x{cam.image_height_px:<5d}{cam.hfov_deg:>7.1f}°{cam.vfov_deg:>7.1f}°")
    return 0


def cmd_evaluate(args) -> int:
    from .evaluate import evaluate
    from .route import Route
    if args.spacing is not None:
        check_positive("--spacing", args.spacing)
    route = Route.load(args.route)
    scene = _scene(args)
    ev = evaluate(route, scene, spacing=args.spacing)
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


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="coverplan", description="Plan safe drone photo flights that cover a building.")
    parser.add_argument("--version", action="version", version=f"coverplan {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    p = sub.add_parser("cameras", help="list the camera presets")
    p.set_defaults(func=cmd_cameras)

    p = sub.add_parser("evaluate", help="check a route's coverage and safety against a scene")
    p.add_argument("route", metavar="ROUTE.json")
    _add_scene_args(p, targets_positional=False)
    p.add_argument("--spacing", type=float, default=None, metavar="M",
                   help="surface sample spacing in metres (default: the planner's, else d_opt/8)")
    p.add_argument("--json", action="store_true", help="print the metrics as JSON")
    p.add_argument("--strict", action="store_true",
                   help="exit 1 when the route is unsafe or coverage is below --min-coverage")
    p.add_argument("--min-coverage", type=float, default=None, metavar="PCT")
    p.set_defaults(func=cmd_evaluate)
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


if __name__ == "__main__":
    sys.exit(main())
