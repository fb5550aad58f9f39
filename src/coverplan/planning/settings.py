"""PlanSettings: every setting of a plan, with its default and its range check, in one place."""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from coverplan.equipment.camera import Camera, check_positive
from coverplan.equipment.margin import MARGINS
from coverplan.errors import ParameterError, PlanningError
from coverplan.flight.passing import PassRules
from coverplan.flight.tour import DEFAULT_LANE_STEPS, DEFAULT_REAIM_STEPS, DEFAULT_REVERSAL_STEPS
from coverplan.shots.candidates import VIEW_TILTS
from coverplan.shots.existing import ExistingShots
from coverplan.shots.reconstructability import MatchRule
from coverplan.shots.selection import LP_TIME_LIMIT_S
from coverplan.world.zones import Zones

RULES = ("sfm", "thesis")
SELECTIONS = ("shots", "lanes")
FLY = ("through", "stop")
DEFAULT_CEILING_M = 120.0  # EU (EASA open category), UK CAA, US FAA Part 107: 120 m / 400 ft above the ground


@dataclass(frozen=True)
class PlanSettings:
    """What the plan must achieve and how hard the planner may work for it.

    Parameters
    ----------
    gsd : float
        Ground sample distance asked for, m/px; with the camera it fixes the optimal
        distance ``d_opt``.
    security : float
        Distance the drone keeps from every mesh and the ground, m.
    rule : {"sfm", "thesis"}
        "sfm" plans for a reconstruction (``min_views`` 3, pairs that triangulate and match,
        shots linked into one matchable set, reconstructability.py); "thesis" is the thesis's
        rule (``min_views`` 2, any pair wide enough).
    min_views : int or None
        Views per sample; None takes the rule's (3 for "sfm", 2 for "thesis").
    min_triangulation_deg : float
        Narrowest pair angle that triangulates, degrees in [0, 90).
    match : MatchRule or None
        The "sfm" rule's matching settings; None takes ``MatchRule()`` (and is None under
        "thesis").
    max_incidence_deg : float
        Steepest view on a surface, degrees in (0, 90).
    min_altitude : float or None
        Lowest flight height above the ground, m; None: the security distance.
    spacing : float or None
        Surface sample spacing, m; None: from the scene and ``d_opt``.
    gimbal_pitch_range_deg : (2,) float or None
        Gimbal pitch range; None: the drone's, else -90..30.
    cost_weight : float
        Weight of the security + optimal placement cost in the flight graph.
    max_flight_min : float or None
        Longest battery flight in minutes; None: the drone's usable minutes, or no split.
    max_mission_items : int or None
        Most mission items a flight may hold as the QGroundControl plan and the WPL file write
        it (PX4 keeps 500 on a flight controller); None: no limit. Flights are split to fit.
    lattice_spacing_m : float or None
        Flight-graph lattice spacing; None: chosen to keep the lattice within its node cap.
    lp_time_limit : float
        Seconds the view-selection LP may take (0: none, plain greedy). An LP that reaches it
        is dropped and the plan warns: the shots then depend on the machine's speed.
    max_memory : float or None
        Bytes the plan may use; None: 80 % of this machine's RAM.
    surface_classes : tuple of str or None
        Plan only these surface classes (roof, facade, ...).
    pose_margin : {"field", "none"}
        "field" judges frames and pair angles with the drone's own pose error (margin.py);
        "none" with the rules as given.
    max_altitude : float or None
        The ceiling, m above the ground under the drone (120 m: the EU, UK and US limit);
        None: none. Surface seen only from above it is reported, not planned.
    zones : Zones
        Keep-out and keep-in prisms (world/zones.py, ``io.zones.read_zones``): no waypoint or
        segment enters a keep-out zone or leaves the keep-in region. Surface seen only from
        a zone is reported, not planned.
    zone_margin : float or None
        How far the flight keeps from the zones, m, against its own position error: keep-out
        zones grown and keep-in zones shrunk by it, sideways and in height; None: the drone's
        horizontal position accuracy (1.5 m, a GNSS drone's, without a drone profile).
    fly : {"through", "stop"}
        "through" takes photos in passing where the turn, motion blur, the photo interval and
        the heading and gimbal turns allow it (flight/passing.py) and stops elsewhere; "stop"
        stops at every waypoint. The shots are the same either way.
    pass_rules : PassRules
        Blur, photo offset, turn and speed limits of flying through.
    view_tilts : {"varied", "corners", "square"}
        The candidates' view directions. "varied" faces each wall from the façade rings at
        three headings (square-on and a third of the field of view either side) and looks
        along each surface normal and 30 deg off it four ways; "square" keeps only the
        square-on views, so photos along a wall share one heading; "corners" is "square"
        with the rings' tilted views kept where a ring turns a corner (steps toward lanes,
        docs/flights.md).
    edge_views : bool or None
        Take a photo from the bisector of the two faces every frame width along each edge
        where the surface turns by 45 deg or more (``edge_views.edge_views``), seeing both
        faces alike, so that SfM joins each face to the next; False: without them. None (the
        default): on under the ``"sfm"`` rule (lanes need them too: wrapped round a corner
        alone, they split in field draws), off under the thesis's.
    reversal_steps : float
        How much path the tour gives up to avoid one reversal, a photo where the direction of
        travel turns by more than 90 deg and the drone must stop, in typical steps (the median
        distance from a shot to its nearest; flight/tour.py); 0: the shortest tour.
    reaim_steps : float
        How much path the tour gives up to fly two photos one after the other whose camera
        need not turn between them (a smooth step: heading within 10 deg, gimbal pitch within
        5 deg), in typical steps; 0: no preference.
    existing : ExistingShots or None
        Photos already taken (shots/existing.py): their views count toward every rule and the
        new flight takes only what they do not give.
    selection : {"shots", "lanes"}
        "shots" chooses photos one by one from every candidate viewpoint, then adds the views
        and links SfM asks; "lanes" first chooses whole lanes (runs of photos along façades and
        over roofs, one heading and gimbal pitch each, shots/lanes.py) and leaves single shots
        to what no lane sees.
    forward_overlap : float
        Under "lanes": the share of the frame consecutive photos of a lane share, in [0.3, 0.95).
    side_overlap : float
        Under "lanes": the share of the frame neighbouring lanes (bands, roof strips) share,
        in [0, 0.95).
    lane_steps : float
        Under "lanes": how much path the tour gives up to fly a lane's photos one after the
        other, end to end, in typical steps.
    force : bool
        Plan even when the GSD, security distance, lowest altitude or flight time look like a
        unit slip (planning/guards.py); False (the default) refuses them with one line.
    """

    gsd: float
    security: float
    rule: str = "sfm"
    min_views: int | None = None
    min_triangulation_deg: float = 5.0
    match: MatchRule | None = None
    max_incidence_deg: float = 70.0
    min_altitude: float | None = None
    spacing: float | None = None
    gimbal_pitch_range_deg: tuple | None = None
    cost_weight: float = 1.0
    max_flight_min: float | None = None
    max_mission_items: int | None = None
    lattice_spacing_m: float | None = None
    lp_time_limit: float = LP_TIME_LIMIT_S
    max_memory: float | None = None
    surface_classes: tuple | None = field(default=None)
    pose_margin: str = "field"
    max_altitude: float | None = DEFAULT_CEILING_M
    zones: Zones = field(default_factory=Zones)
    zone_margin: float | None = None
    fly: str = "through"
    pass_rules: PassRules = field(default_factory=PassRules)
    view_tilts: str = "varied"
    edge_views: bool | None = None
    reversal_steps: float = DEFAULT_REVERSAL_STEPS
    reaim_steps: float = DEFAULT_REAIM_STEPS
    existing: ExistingShots | None = None
    selection: str = "shots"
    forward_overlap: float = 0.7
    side_overlap: float = 0.4
    lane_steps: float = DEFAULT_LANE_STEPS
    force: bool = False

    def __post_init__(self):
        def put(name, value):
            object.__setattr__(self, name, value)

        put("gsd", check_positive("gsd", self.gsd))
        put("security", check_positive("security distance", self.security))
        if self.rule not in RULES:
            raise ParameterError(f"rule must be one of {', '.join(RULES)}, got {self.rule!r}")
        if self.fly not in FLY:
            raise ParameterError(f"fly must be one of {', '.join(FLY)}, got {self.fly!r}")
        if self.selection not in SELECTIONS:
            raise ParameterError(f"selection (--selection) must be one of {', '.join(SELECTIONS)}, "
                                 f"got {self.selection!r}")
        if not (np.isfinite(self.forward_overlap) and 0.3 <= self.forward_overlap < 0.95):
            raise ParameterError(f"the forward overlap (--forward-overlap) must be a share in [0.3, 0.95), "
                                 f"got {self.forward_overlap!r}")
        if not (np.isfinite(self.side_overlap) and 0.0 <= self.side_overlap < 0.95):
            raise ParameterError(f"the side overlap (--side-overlap) must be a share in [0, 0.95), "
                                 f"got {self.side_overlap!r}")
        if self.view_tilts not in VIEW_TILTS:
            raise ParameterError(f"view tilts must be one of {', '.join(VIEW_TILTS)}, got {self.view_tilts!r}")
        if self.pose_margin not in MARGINS:
            raise ParameterError(f"pose margin must be one of {', '.join(MARGINS)}, got {self.pose_margin!r}")
        min_views = (3 if self.rule == "sfm" else 2) if self.min_views is None else self.min_views
        if int(min_views) != min_views or min_views < 1:
            raise ParameterError(f"min views must be a whole number >= 1, got {min_views!r}")
        put("min_views", int(min_views))
        put("match", (self.match or MatchRule()) if self.rule == "sfm" else None)
        put("edge_views", self.rule == "sfm" if self.edge_views is None else bool(self.edge_views))
        if not 0 <= float(self.min_triangulation_deg) < 90:
            raise ParameterError(f"min triangulation angle must be in [0, 90) degrees, got {self.min_triangulation_deg!r}")
        if self.match and not float(self.min_triangulation_deg) < self.match.max_pair_deg:
            raise ParameterError(f"min triangulation angle {self.min_triangulation_deg:g} deg must be below the widest "
                                 f"matchable pair {self.match.max_pair_deg:g} deg")
        if not 0 < float(self.max_incidence_deg) < 90:
            raise ParameterError(f"max incidence must be in (0, 90) degrees, got {self.max_incidence_deg!r}")
        if self.min_altitude is not None and not np.isfinite(self.min_altitude):
            raise ParameterError(f"min altitude must be a finite number, got {self.min_altitude!r}")
        if self.spacing is not None:
            put("spacing", check_positive("spacing", self.spacing))
        if self.max_flight_min is not None:
            put("max_flight_min", check_positive("max flight minutes", self.max_flight_min))
        if not (np.isfinite(self.lp_time_limit) and self.lp_time_limit >= 0):
            raise ParameterError(f"the LP time limit (--lp-time-limit) must be >= 0 seconds (0: no LP), "
                                 f"got {self.lp_time_limit!r}")
        if self.max_mission_items is not None:
            items = self.max_mission_items
            if isinstance(items, bool) or not (np.isfinite(items) and int(items) == items and items >= 8):
                raise ParameterError(f"max mission items must be a whole number >= 8, got {items!r}")
            put("max_mission_items", int(items))
        if self.surface_classes is not None:
            put("surface_classes", tuple(self.surface_classes))
        if self.max_altitude is not None:
            put("max_altitude", check_positive("altitude ceiling (--max-altitude)", self.max_altitude))
            if self.max_altitude <= self.floor:
                why = "" if self.min_altitude is not None else (
                    f" (the security distance, --security {self.security:g} m: a unit slip?)")
                raise ParameterError(f"the altitude ceiling (--max-altitude) {self.max_altitude:g} m is not above the "
                                     f"minimum altitude {self.floor:g} m{why}")
        if not isinstance(self.zones, Zones):
            put("zones", Zones(tuple(self.zones)))
        if not (np.isfinite(self.reversal_steps) and self.reversal_steps >= 0):
            raise ParameterError(f"the reversal cost (--reversal-cost) must be a number of steps >= 0, "
                                 f"got {self.reversal_steps!r}")
        put("reversal_steps", float(self.reversal_steps))
        if not (np.isfinite(self.reaim_steps) and self.reaim_steps >= 0):
            raise ParameterError(f"the re-aim cost (--reaim-cost) must be a number of steps >= 0, "
                                 f"got {self.reaim_steps!r}")
        put("reaim_steps", float(self.reaim_steps))
        if not (np.isfinite(self.lane_steps) and self.lane_steps >= 0):
            raise ParameterError(f"the lane cost (--lane-cost) must be a number of steps >= 0, got {self.lane_steps!r}")
        put("lane_steps", float(self.lane_steps))
        if self.zone_margin is not None and not (np.isfinite(self.zone_margin) and self.zone_margin >= 0):
            raise ParameterError(f"the zone margin (--zone-margin) must be a number of metres >= 0, "
                                 f"got {self.zone_margin!r}")

    @property
    def floor(self) -> float:
        """The minimum altitude the plan keeps above the ground, m."""
        return self.security if self.min_altitude is None else float(self.min_altitude)


def safety_margin(security: float) -> float:
    """Extra clearance the planner keeps beyond the security distance.

    Parameters
    ----------
    security : float
        The security distance, metres.

    Returns
    -------
    float
        Metres.
    """
    return max(0.05, 0.02 * security)


def optimal_distance(camera: Camera, settings: PlanSettings) -> float:
    """``d_opt`` of the GSD asked, refused when it lies inside the security distance.

    Parameters
    ----------
    camera : Camera
        The camera flown.
    settings : PlanSettings
        Gives the GSD and the security distance.

    Returns
    -------
    float
        ``d_opt`` in metres.

    Raises
    ------
    ParameterError
        When ``d_opt`` is not beyond the security distance.
    """
    d_opt = camera.optimal_distance(settings.gsd)
    need = settings.security + safety_margin(settings.security)
    if d_opt <= need * 1.05:
        finest = need * 1.05 * camera.pixel_pitch_mm / camera.focal_length_mm
        raise PlanningError(
            f"GSD {settings.gsd:g} m/px needs shots within {d_opt:.2f} m of the surface, but the security "
            f"distance is {settings.security:g} m; the finest GSD possible with this camera and security "
            f"distance is about {finest:.4g} m/px")
    return d_opt


def gimbal_range(given, drone) -> tuple[float, float]:
    """The gimbal pitch range to plan with: the one given, else the drone's, else -90..30.

    Parameters
    ----------
    given : (float, float) or None
        Lowest and highest pitch asked, degrees.
    drone : DroneProfile or None
        The drone flown.

    Returns
    -------
    lo, hi : float
        Degrees.
    """
    rng = given if given is not None else (drone.gimbal_pitch_deg if drone is not None else (-90.0, 30.0))
    lo, hi = (float(v) for v in rng)
    if not -90.0 <= lo <= hi <= 90.0:
        raise ParameterError(f"gimbal pitch range must lie in [-90, 90] with min <= max, got {tuple(rng)}")
    if given is not None and drone is not None:
        d_lo, d_hi = drone.gimbal_pitch_deg
        if lo < d_lo or hi > d_hi:
            raise ParameterError(f"gimbal pitch range {lo:g}..{hi:g} deg is beyond the {drone.label}'s "
                                 f"{d_lo:g}..{d_hi:g} deg")
    return lo, hi


# Bytes per item, measured on the 3.2-million-triangle benchmark mesh and sample scenes
# (peak resident memory over the counts), rounded up.
BYTES_PER_TRIANGLE = 1400
BYTES_PER_SAMPLE = 3000
BYTES_PER_VIEW_PAIR = 160
BYTES_PER_CANDIDATE = 400


def physical_memory() -> float:
    """Bytes of RAM on this machine (sysconf), or 8 GB where it cannot be read.

    Returns
    -------
    float
        Bytes.
    """
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 8e9


def memory_estimate(scene, camera: Camera, spacing: float, distance: float) -> dict:
    """Rough peak memory of a plan, from triangles, samples and expected visibility pairs.

    Parameters
    ----------
    scene : Scene
        The scene.
    camera : Camera
        The camera flown.
    spacing : float
        The samples' spacing, metres.
    distance : float
        The camera distance, metres.

    Returns
    -------
    dict
        ``bytes`` and the counts it comes from (triangles, samples, candidates, pairs).
    """
    triangles = sum(len(p.mesh.faces) for p in scene.parts)
    area = sum(p.mesh.area for p in scene.targets)
    samples = area / spacing ** 2
    width, height = camera.footprint(distance)
    candidates = 12.0 * area / max(width * height, spacing ** 2) + 500.0
    per_view = min(samples, width * height / spacing ** 2)
    pairs = candidates * per_view * 0.6
    total = (triangles * BYTES_PER_TRIANGLE + samples * BYTES_PER_SAMPLE + pairs * BYTES_PER_VIEW_PAIR
             + candidates * BYTES_PER_CANDIDATE + 3e8)
    return {"bytes": total, "triangles": triangles, "samples": samples, "candidates": candidates, "pairs": pairs}


def check_size(scene, camera: Camera, spacing: float, distance: float, max_memory: float | None) -> dict:
    """Refuse, before any heavy work, a plan that would not fit in memory.

    Parameters
    ----------
    scene : Scene
        The scene.
    camera : Camera
        The camera flown.
    spacing : float
        The samples' spacing, metres.
    distance : float
        The camera distance, metres.
    max_memory : float or None
        The bytes a plan may use; None allows most of this machine's memory.

    Returns
    -------
    dict
        ``memory_estimate``'s result.

    Raises
    ------
    ParameterError
        When the estimate exceeds the memory allowed.
    """
    limit = 0.8 * physical_memory() if max_memory is None else float(max_memory)
    est = memory_estimate(scene, camera, spacing, distance)
    if est["bytes"] > limit:
        raise PlanningError(
            f"this plan needs about {est['bytes'] / 1e9:.1f} GB ({est['triangles']:,} triangles, "
            f"~{est['samples']:,.0f} surface samples at {spacing:.3g} m, ~{est['pairs']:,.0f} view pairs) but "
            f"the limit is {limit / 1e9:.1f} GB; use a coarser --spacing or GSD, or raise --max-memory-gb")
    return est
