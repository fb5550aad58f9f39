"""Resolving the settings against the scene, camera and drone: what every stage works with."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import shapely

from coverplan.equipment.camera import Camera
from coverplan.equipment.drones import TYPICAL_GNSS, DroneProfile
from coverplan.equipment.flighttime import FlightModel
from coverplan.equipment.margin import NO_MARGIN, PoseMargin, margin_for, tightened
from coverplan.errors import ParameterError
from coverplan.flight.lattice import lattice_spacing
from coverplan.flight.start import check_start, default_start
from coverplan.planning.guards import check_unit_slips
from coverplan.planning.settings import (
    PlanSettings,
    check_size,
    gimbal_range,
    optimal_distance,
    safety_margin,
)
from coverplan.shots.candidates import (
    standoff,
)
from coverplan.shots.limits import ViewLimits, scene_limits
from coverplan.shots.reconstructability import MatchRule
from coverplan.shots.surface import default_spacing

MAX_LATTICE_NODES = 150_000


@dataclass(frozen=True)
class Setup:
    """The settings resolved against the scene, camera and drone: what every stage works with.

    ``camera``, ``match`` and ``min_triangulation_deg`` are the ones the rules are judged with
    (narrowed by the pose margin); ``asked`` keeps the settings as given for the route.

    Parameters
    ----------
    asked : PlanSettings
        The settings as given.
    asked_camera : Camera
        The camera as given.
    camera : Camera
        The camera narrowed by the pose margin.
    limits : ViewLimits
        The viewpoint rules.
    pose : PoseMargin
        The drone's position, heading and gimbal error the rules are judged with.
    match : MatchRule or None
        The matching rule.
    min_triangulation_deg : float
        The least angle between two rays of a triangulating pair.
    d_opt : float
        The camera distance of the GSD asked, metres.
    extra_clearance : float
        Clearance kept beyond the security distance, metres.
    spacing : float
        The planner's sample spacing, metres.
    standoff : float
        The distance candidates are placed at, metres.
    start : (3,) float
        The take-off point.
    flight_model : FlightModel
        The flight-time model.
    max_flight_min : float or None
        The longest battery flight.
    drone : DroneProfile or None
        The drone flown.
    notes : tuple of str
        Notes for the route.
    """

    asked: PlanSettings
    asked_camera: Camera
    camera: Camera
    limits: ViewLimits
    pose: PoseMargin
    match: MatchRule | None
    min_triangulation_deg: float
    d_opt: float
    extra_clearance: float  # beyond the security distance (safety_margin)
    spacing: float
    standoff: float
    start: np.ndarray  # (3,)
    flight_model: FlightModel
    max_flight_min: float | None
    drone: DroneProfile | None
    notes: tuple

    @property
    def max_pair_deg(self) -> float | None:
        """The largest angle between the rays of a matching pair, or None without a matching rule."""
        return self.match.max_pair_deg if self.match else None


def resolve(scene, camera: Camera, settings: PlanSettings, drone: DroneProfile | None = None,
            flight_model: FlightModel | None = None, start=None) -> Setup:
    """Check the settings against the camera and scene; the pose margin, limits and start point.

    Parameters
    ----------
    scene : Scene
        The scene planned.
    camera : Camera
        The camera flown.
    settings : PlanSettings
        The settings asked.
    drone : DroneProfile, optional
        The drone flown.
    flight_model : FlightModel, optional
        The flight-time model; the drone's, else a default.
    start : (3,) float, optional
        The take-off point; picked when None.

    Returns
    -------
    Setup
        The resolved settings.
    """
    d_opt = optimal_distance(camera, settings)
    check_unit_slips(scene, settings, d_opt)
    pitch_range = gimbal_range(settings.gimbal_pitch_range_deg, drone)
    model = flight_model or (drone.flight_model() if drone is not None else FlightModel())
    max_flight_min = settings.max_flight_min
    if max_flight_min is None and drone is not None:
        max_flight_min = drone.usable_flight_min
    limits = scene_limits(scene, security=settings.security, d_opt=d_opt, max_incidence_deg=settings.max_incidence_deg,
                          min_altitude=settings.floor, pitch_range_deg=pitch_range, vfov_deg=camera.vfov_deg,
                          max_altitude=settings.max_altitude, zones=settings.zones.grown(zone_margin(settings, drone)))
    extra = safety_margin(settings.security)
    # The rules judged with the drone's pose error: a narrower frame, narrower pair angles.
    asked_camera, match = camera, settings.match
    min_triangulation_deg = float(settings.min_triangulation_deg)
    pose = margin_for(settings.pose_margin, drone, standoff(camera, limits, extra))
    if pose != NO_MARGIN:
        camera = pose.camera(camera)
        match, min_triangulation_deg = tightened(match, min_triangulation_deg, pose)
        if match and not min_triangulation_deg < match.max_pair_deg:
            raise ParameterError(f"with the pose margin the narrowest triangulating pair "
                                 f"({min_triangulation_deg:.1f} deg) is not below the widest matchable one ({match.max_pair_deg:.1f} deg); "
                                 "widen --max-pair-deg or use --pose-margin none")
        limits = replace(limits, vfov_deg=camera.vfov_deg)
    spacing = default_spacing(scene, d_opt) if settings.spacing is None else settings.spacing
    distance = standoff(camera, limits, extra)
    check_size(scene, camera, spacing, distance, settings.max_memory)
    check_zones(scene, limits)
    notes = []
    if start is None:
        start = default_start(scene, limits, extra)
    else:
        start, notes = check_start(scene, start, limits)
    return Setup(settings, asked_camera, camera, limits, pose, match, min_triangulation_deg, d_opt, extra, spacing,
                 distance, start, model, max_flight_min, drone, tuple(notes))


def zone_margin(settings: PlanSettings, drone: DroneProfile | None) -> float:
    """The margin the flight keeps from the zones, m: the one asked, else the drone's
    horizontal position accuracy (a GNSS drone's without a profile).

    Parameters
    ----------
    settings : PlanSettings
        The settings asked.
    drone : DroneProfile or None
        The drone flown.

    Returns
    -------
    float
        Metres.
    """
    if settings.zone_margin is not None:
        return float(settings.zone_margin)
    return float((drone.position if drone is not None else TYPICAL_GNSS).horizontal_m)


def check_zones(scene, limits: ViewLimits) -> None:
    """Refuse zones that leave no airspace to photograph the target from.

    Parameters
    ----------
    scene : Scene
        The scene with its zones.
    limits : ViewLimits
        The viewpoint rules.

    Raises
    ------
    ParameterError
        A zone narrower than twice the zone margin, or zones that cover the whole target or
        leave no airspace within d_opt of it.
    """
    if not limits.zones:
        return
    for zone in limits.zones.keep_in:
        if zone.polygon.is_empty or zone.floor >= zone.ceiling:
            raise ParameterError(f"{zone.label} is narrower than twice the zone margin (--zone-margin): "
                                 "no room to fly inside it")
    pts = np.vstack([p.mesh.vertices for p in scene.targets])
    reach = limits.d_opt
    outline = shapely.MultiPoint(pts[:, :2]).convex_hull.buffer(reach)
    low = float(limits.floor_at(pts[:, :2]).min())
    high = float(pts[:, 2].max() + reach)
    closed = limits.zones.closing_off(outline, low, high)
    if closed and closed[0].startswith("keep-out"):
        raise ParameterError(f"{' and '.join(closed)} cover{'s' if len(closed) == 1 else ''} the whole target and "
                             f"the airspace within d_opt {reach:.1f} m of it: nothing could be photographed")
    if closed:
        raise ParameterError(f"{' and '.join(closed)} do{'es' if len(closed) == 1 else ''} not reach within d_opt "
                             f"{reach:.1f} m of the target: nothing could be photographed from inside it")


def plan_lattice_spacing(scene, shots: np.ndarray, setup: Setup) -> float:
    """The flight graph's lattice spacing: the one asked, or one that keeps the lattice over the
    target and its shots within MAX_LATTICE_NODES.

    Parameters
    ----------
    scene : Scene
        The scene.
    shots : (k, 3) float
        The shot positions.
    setup : Setup
        The resolved settings.

    Returns
    -------
    float
        Metres.
    """
    security = setup.asked.security
    region = np.ptp(np.vstack([scene.bounds("target"), shots]), axis=0) + 2 * (setup.d_opt + security)
    return setup.asked.lattice_spacing_m or lattice_spacing(setup.d_opt, security, float(np.prod(region)),
                                                            MAX_LATTICE_NODES)
