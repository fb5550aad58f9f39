"""The flags the subcommands share (scene, camera, mission, planning, zones, simulate, exports), defined once, in the help's groups."""

from __future__ import annotations

import argparse
import sys

from coverplan.equipment.camera import PRESETS
from coverplan.flight.tour import DEFAULT_LANE_STEPS, DEFAULT_REAIM_STEPS, DEFAULT_REVERSAL_STEPS
from coverplan.planning.settings import DEFAULT_CEILING_M, LP_TIME_LIMIT_S, SELECTIONS
from coverplan.sfm.colmap import MAX_FEATURES, SPATIAL_NEIGHBOURS
from coverplan.sfm.mapping import GLOBAL_MAPPING_ABOVE
from coverplan.shots.reconstructability import LINK_TESTS


class DeprecatedAlias(argparse.Action):
    """An option that still answers to its old name (``old``), with a warning that says the new one.

    Parameters
    ----------
    option_strings : list of str
        The option's names, the new one first.
    dest : str
        The attribute set.
    old : str
        The old name.
    **kwargs
        ``argparse.Action``'s other arguments.
    """

    def __init__(self, option_strings, dest, old: str, **kwargs):
        self.old, self.warned = old, False
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        if option_string == self.old and not self.warned:  # once, though main parses the line twice
            self.warned = True
            print(f"coverplan: {self.old} is now {self.option_strings[0]} (the old name goes in the next release)",
                  file=sys.stderr)
        setattr(namespace, self.dest, values)


def add_scene_args(p, targets_positional: bool, recorded: bool = False):
    """The scene's files and options; ``recorded``: a route's own record of its scene is the default.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser.
    targets_positional : bool
        The targets are positional arguments, not ``--target``.
    recorded : bool
        The route's record of its scene is the default.
    """
    if targets_positional:
        p.add_argument("targets", nargs="+", metavar="TARGET", help="target mesh file(s)")
    else:
        p.add_argument("--target", "--targets", dest="targets", nargs="+", required=not recorded, default=None,
                       metavar="TARGET",
                       help="target mesh file(s)" + (" (default: the scene the route records; the other scene "
                                                     "options then come from the route too)" if recorded else ""))
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
    p.add_argument("--lod", type=int, default=None, metavar="N",
                   help="CityGML/CityJSON: level of detail (default: highest)")
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


def add_mission_args(p):
    """The camera, GSD and security distance a mission from another app is judged by.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser.
    """
    add_camera_args(p)
    p.add_argument("--gsd", type=float, default=None, metavar="M_PER_PX",
                   help="for missions: the GSD to judge the photos by")
    p.add_argument("--security", type=float, default=None, metavar="M",
                   help="for missions: the security distance to judge the flight by")


FLIGHTS_HELP = ("a coverplan route (.json) or a mission: QGroundControl .plan, QGC WPL .waypoints, Litchi .csv, DJI "
                "WPML .kmz; several (or a pattern such as 'house.f*.kmz') are judged together as one plan's battery "
                "flights (docs/evaluate.md)")


def add_camera_args(p):
    """Add the camera flags: ``--camera`` or a custom sensor, focal length and image size.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser.
    """
    p.add_argument("--camera", default=None, metavar="PRESET",
                   help=f"camera preset: {', '.join(sorted(PRESETS))} (see 'coverplan cameras')")
    p.add_argument("--sensor-mm", nargs=2, type=float, default=None, metavar=("W", "H"),
                   help="a camera without a preset: sensor width and height in mm (with --focal-mm, --image-px)")
    p.add_argument("--focal-mm", type=float, default=None, metavar="F",
                   help="a camera without a preset: the lens's real focal length in mm (not the 35 mm equivalent)")
    p.add_argument("--image-px", nargs=2, type=float, default=None, metavar=("W", "H"),
                   help="a camera without a preset: photo width and height in pixels")


ROUTE_CEILING = object()  # evaluate's default: the ceiling the route records


def parse_ceiling(text: str) -> float | None:
    """``--max-altitude``'s value: metres, or None for ``none``.

    Parameters
    ----------
    text : str
        The value given.

    Returns
    -------
    float or None
        Metres above the ground.
    """
    if text.strip().lower() == "none":
        return None
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected metres or 'none', got {text!r}") from None


def add_mapper_arg(p):
    """Add ``--mapper``.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser.
    """
    p.add_argument("--mapper", default="auto", choices=("auto", "incremental", "global"),
                   help="COLMAP's incremental mapper or its global one (GLOMAP); auto (default): global above "
                        f"{GLOBAL_MAPPING_ABOVE} photos, where the incremental one split flights that the global "
                        "one kept whole")


def add_simulate_args(p):
    """Add the flags ``simulate`` and ``plan --simulate`` share: photo width, conditions, draws, matching, features, lens, texture, threads.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser.
    """
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
    add_mapper_arg(p)
    p.add_argument("--lens", default="pinhole", choices=("pinhole", "drone"),
                   help="pinhole (default): photos without distortion; drone: drawn through the drone profile's "
                        "own lens distortion (raw photos, as the camera takes them with its correction off)")
    p.add_argument("--texture", default="noise", choices=("noise", "cells"),
                   help="texture family under field/harsh conditions: noise (value noise) or cells (cellular stone)")
    p.add_argument("--threads", type=int, default=-1, metavar="N", help="threads for SfM (default: all cores)")


GROUPS = (("scene", "scene"), ("camera", "camera and drone"), ("quality", "quality"),
          ("safety", "safety and airspace"), ("flight", "flight"), ("exports", "outputs and exports"),
          ("advanced", "advanced: view selection and tour (the defaults are the tested ones)"))


def option_groups(p) -> dict:
    """The help's groups of planning options, in the order a surveyor sets them.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser.

    Returns
    -------
    dict of str to argparse._ArgumentGroup
        The groups by key.
    """
    return {key: p.add_argument_group(title) for key, title in GROUPS}


def add_planning_args(p) -> dict:
    """The camera and planning flags ``plan`` and ``batch`` share, in the help's groups
    (``option_groups``); returns the groups, for the command's own flags.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser.

    Returns
    -------
    dict of str to argparse._ArgumentGroup
        The groups by key.
    """
    groups = option_groups(p)
    c, q, s, f, x, a = (groups[k] for k in ("camera", "quality", "safety", "flight", "exports", "advanced"))
    add_camera_args(c)
    q.add_argument("--gsd", type=float, required=True, metavar="M_PER_PX", help="target ground sampling distance")
    s.add_argument("--security", type=float, required=True, metavar="M",
                   help="security distance to keep from every mesh")
    q.add_argument("--rule", choices=["sfm", "thesis"], default="sfm",
                   help="sfm (default): plan for a reconstruction (docs/reconstruction.md); "
                        "thesis: 2 views 5 deg apart, the thesis's rule, for comparison")
    s.add_argument("--pose-margin", "--margin", dest="margin", action=DeprecatedAlias,
                   old="--margin", choices=["field", "none"], default="field",
                   help="field (default): judge frames and view-pair angles with the drone's own position, heading "
                        "and gimbal error (docs/reconstruction.md); none: the rules as given")
    f.add_argument("--fly", choices=["through", "stop"], default="through",
                   help="through (default): take photos in passing where the turn, motion blur, the photo interval "
                        "and the heading and gimbal turns allow it, and stop elsewhere (docs/flights.md); "
                        "stop: stop at every waypoint. The photos are the same")
    a.add_argument("--view-tilts", choices=["varied", "corners", "square"], default="varied",
                   help="varied (default): candidate views square-on to the surface and tilted off it; corners: "
                        "tilted only where the façade rings turn a corner; square: square-on only, so photos "
                        "along a wall share one heading (docs/flights.md, \"Lanes\")")
    a.add_argument("--edge-views", choices=["on", "off"], default=None,
                   help="on (default under --rule sfm): a photo from the bisector of the two faces every frame width "
                        "along each edge where the surface turns (a corner, an eave), seeing both faces alike "
                        "(docs/reconstruction.md, \"Edge views\"); off (default under --rule thesis): without them")
    a.add_argument("--reversal-cost", type=float, default=DEFAULT_REVERSAL_STEPS, metavar="STEPS",
                   help=f"how much path the tour gives up to avoid one reversal (a photo where the flight turns back "
                        f"by more than 90 deg and must stop), in typical steps between neighbouring photos (default "
                        f"{DEFAULT_REVERSAL_STEPS:g}; 0: the shortest tour; docs/flights.md, \"The order\")")
    a.add_argument("--reaim-cost", type=float, default=DEFAULT_REAIM_STEPS, metavar="STEPS",
                   help=f"how much path the tour gives up to fly next to each other two photos whose camera need "
                        f"not turn between them (heading within 10 deg, pitch within 5 deg), in typical steps "
                        f"(default {DEFAULT_REAIM_STEPS:g}; 0: no preference)")
    f.add_argument("--selection", choices=list(SELECTIONS), default="shots",
                   help="shots (default): photos chosen one by one from every candidate view; lanes: whole runs of "
                        "photos along façades and over roofs first, single shots only where no lane sees "
                        "(docs/flights.md, \"Lanes\")")
    a.add_argument("--forward-overlap", type=float, default=0.7, metavar="SHARE",
                   help="lanes: share of the frame consecutive photos of a lane share (default 0.7)")
    a.add_argument("--side-overlap", type=float, default=0.4, metavar="SHARE",
                   help="lanes: share of the frame neighbouring lanes (bands, roof strips) share (default 0.4)")
    a.add_argument("--lane-cost", type=float, default=DEFAULT_LANE_STEPS, metavar="STEPS",
                   help=f"lanes: how much path the tour gives up to fly each lane end to end, in typical steps "
                        f"(default {DEFAULT_LANE_STEPS:g})")
    q.add_argument("--min-views", type=int, default=None, metavar="N",
                   help="views per surface point (default 3; thesis rule 2)")
    q.add_argument("--min-triangulation-deg", type=float, default=5.0, metavar="DEG",
                   help="narrowest angle between two views of a point that triangulates it (default 5)")
    a.add_argument("--max-pair-deg", type=float, default=None, metavar="DEG",
                   help="sfm rule: widest view pair SfM is trusted to match (default 35)")
    a.add_argument("--min-overlap", type=float, default=None, metavar="FRACTION",
                   help="sfm rule: surface two linked photos share (default 0.3)")
    a.add_argument("--min-neighbours", type=int, default=None, metavar="N",
                   help="sfm rule: linked photos every photo needs (default 2)")
    a.add_argument("--links", choices=["braced", "one-piece"], default=None,
                   help="sfm rule: braced (default): no photo is the only link between two groups of photos; "
                        "one-piece: the photos only need to link into one set")
    a.add_argument("--min-cut", type=int, default=None, metavar="LINKS",
                   help="sfm rule: links that join every group of 4 or more photos to the rest "
                        "(default 0: not asked; 3 knits groups that hang on two links, docs/reconstruction.md)")
    a.add_argument("--link-test", choices=list(LINK_TESTS), default=None,
                   help="sfm rule: how two photos' rays to the surface both see are judged: centroid (default): "
                        "at the centroid of all of it; faces: face by face, each within 60 deg of both photos "
                        "(links across a corner count only the faces both photos see squarely); samples: point "
                        "by point, and the plan is chosen lean (fewer photos; experimental: three field draws on the "
                        "gabled house and the chapel only, docs/reconstruction.md)")
    a.add_argument("--sharp-views", type=int, default=None, metavar="N",
                   help="sfm rule: views per surface point within 35 deg of its normal, or as near as any "
                        "safe viewpoint gets plus 5 deg (default 1; 0: none asked)")
    a.add_argument("--framed-views", type=int, default=None, metavar="N",
                   help="sfm rule: views per surface point whose frame its face fills (25 %%, or most of the best "
                        "any safe viewpoint gives), within 50 deg of its normal; towers and spires get views from "
                        "closer in (default 0: none asked; try 2 for towers and spires)")
    q.add_argument("--max-incidence-deg", type=float, default=70.0, metavar="DEG",
                   help="widest angle between a view and the surface normal that counts as imaging it (default 70)")
    s.add_argument("--min-altitude", type=float, default=None, metavar="M",
                   help="lowest flight height above the ground (default: the security distance)")
    s.add_argument("--max-altitude", type=parse_ceiling, default=DEFAULT_CEILING_M, metavar="M|none",
                   help=f"altitude ceiling above the ground under the drone (default {DEFAULT_CEILING_M:g} m, the EU, "
                        "UK and US limit; 'none': no ceiling)")
    add_zone_args(s)
    c.add_argument("--drone", default=None, metavar="NAME",
                   help="drone profile: camera, gimbal range, speeds, battery (see 'coverplan drones')")
    f.add_argument("--max-flight-min", type=float, default=None, metavar="MIN",
                   help="split the tour into flights of at most MIN minutes each, from the start back to it "
                        "(default: the drone's usable flight time; without --drone one flight)")
    f.add_argument("--max-mission-items", type=int, default=None, metavar="N",
                   help="split the tour so that each flight's QGC plan / WPL file has at most N mission items "
                        "(default: 500, PX4's limit, when plan exports a .plan for PX4; else no limit)")
    c.add_argument("--gimbal-min-deg", type=float, default=None, metavar="DEG",
                   help="lowest gimbal pitch in degrees (default: the drone's, else -90)")
    c.add_argument("--gimbal-max-deg", type=float, default=None, metavar="DEG",
                   help="highest gimbal pitch in degrees (default: the drone's, else 30)")
    a.add_argument("--spacing", type=float, default=None, metavar="M",
                   help="surface sample spacing (default d_opt/8, coarser for huge targets)")
    f.add_argument("--speed", type=float, default=None, metavar="M_PER_S",
                   help="cruise speed between waypoints (default: the drone's, else 5)")
    f.add_argument("--shot-seconds", type=float, default=None, metavar="S",
                   help="hover time per photo in seconds (default: the drone's photo interval, at least 1 s)")
    a.add_argument("--lp-time-limit", type=float, default=LP_TIME_LIMIT_S, metavar="S",
                   help=f"time for the LP that guides view selection and bounds it (default {LP_TIME_LIMIT_S:g}; "
                        "0: plain greedy; an LP that runs out of time is dropped, with a warning)")
    q.add_argument("--only", nargs="+", default=None, metavar="CLASS",
                   choices=["facade", "roof", "terrace", "opposed_terrace"],
                   help="cover only these surfaces (facade, roof, terrace, opposed_terrace)")
    a.add_argument("--max-memory-gb", type=float, default=None, metavar="GB",
                   help="refuse plans estimated to need more (default: 80%% of this machine's RAM)")
    a.add_argument("--merge-obstacles-within", type=float, default=None, metavar="M",
                   help="unite obstacles closer than M to the target with it (thesis Appendix C)")
    x.add_argument("--export", default=None, metavar="FORMATS",
                   help="also write flight files beside the route: qgc,wpl,litchi,wpml,kml,geojson,csv "
                        "(one per battery flight: NAME.f1.plan, ...)")
    add_export_args(x)
    return groups


def add_zone_args(p, judged: bool = False):
    """Add ``--keep-out`` and ``--keep-in``.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser.
    judged : bool
        The zones judge a route rather than shape a plan (the help says so).
    """
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


def add_export_args(p):
    """Add the export flags: ``--firmware`` and ``--wpml-heights``.

    Parameters
    ----------
    p : argparse.ArgumentParser
        The subcommand's parser.
    """
    p.add_argument("--firmware", choices=["px4", "ardupilot"], default="px4", help="for the QGC .plan")
    p.add_argument("--wpml-heights", choices=["relative", "egm96"], default="relative",
                   help="DJI WPML heights: relative to the take-off point (default) or EGM96 (needs a height "
                        "datum and PROJ's geoid grid)")
