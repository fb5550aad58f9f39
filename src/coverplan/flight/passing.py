"""Photos in passing: where the drone flies through a waypoint instead of stopping, how fast,
and where it really is when it passes.

A waypoint is flown through ("turns before the waypoint, flies through": DJI's
``toPointAndPassWithContinuityCurvature`` with ``useStraightLine``) when the path turns there
by at most ``max_turn_deg``; the turn starts ``damping_m`` before the waypoint and ends as far
after it, on a circular arc tangent to both legs. The drone then passes the waypoint at
``d tan(theta / 4)`` from it, on the inside of the turn: the photo's offset, kept within
``max_photo_offset_m`` by shortening the damping distance at photos.

The speed at a waypoint flown through is the least of:

- the turn: ``sqrt(a R)`` on an arc of radius ``R = d / tan(theta / 2)``, at the model's
  acceleration ``a`` sideways;
- at a photo, motion blur: the image moves ``v * shutter * (1 / range + rotation per metre)``
  pixel angles during the exposure (translation seen at the nearest surface in the frame, plus
  heading and gimbal turning evenly along the legs), kept within ``max_blur_px``;
- the top speed of the legs on either side, which keep the horizontal part within the cruise
  speed and the vertical part within the climb or descent rate, take at least as long as their
  heading and gimbal turns, and between two photos at least the camera's shortest photo
  interval.

The speeds along the flight are then the highest that accelerate and brake within ``a`` (a
forward and a backward pass, each a running minimum); each leg is a trapezoidal speed profile
between its end speeds. Where a bound is under ``min_pass_speed`` the drone stops, hovering
``photo_seconds`` at a photo, as the stopping model does. docs/flights.md states the terms.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from coverplan.equipment.drones import SURVEY_SHUTTER_S
from coverplan.errors import ParameterError
from coverplan.flight.corners import _unit, corner_offsets, corner_rows, flown_path, turn_angles
from coverplan.flight.pathing import polyline_checks
from coverplan.flight.speeds import _flown_legs, leg_top_speeds, reachable_speeds
from coverplan.geometry.orientation import camera_axes, heading_change_deg


@dataclass(frozen=True)
class PassRules:
    """When and how fast the drone may take a photo (or pass a transit point) without stopping.

    Parameters
    ----------
    max_blur_px : float
        Image motion during the exposure, pixels.
    max_photo_offset_m : float
        From the planned photo point to where it is taken.
    max_turn_deg : float
        A waypoint where the path turns more is a stop.
    max_damping_m : float
        The turn starts at most this far before the waypoint.
    damping_share : float
        And within this share of the shorter leg.
    min_pass_speed : float
        m/s: slower than this the drone stops instead.
    turn_share : float
        Between two photos, heading and gimbal turn over this middle share of the leg.
    """

    max_blur_px: float = 1.0  # image motion during the exposure, pixels
    max_photo_offset_m: float = 0.1  # from the planned photo point to where it is taken
    max_turn_deg: float = 90.0  # a waypoint where the path turns more is a stop
    max_damping_m: float = 2.0  # the turn starts at most this far before the waypoint
    damping_share: float = 0.4  # and within this share of the shorter leg (both turns fit a leg)
    min_pass_speed: float = 0.3  # m/s: slower than this the drone stops instead
    turn_share: float = 0.5  # between two photos, heading and gimbal turn over this middle share of the leg

    def __post_init__(self):
        for name, value in asdict(self).items():
            if not (np.isfinite(value) and value > 0):
                raise ParameterError(f"pass rule {name.replace('_', ' ')} must be a positive number, got {value!r}")
        if self.max_turn_deg >= 180.0:
            raise ParameterError(f"pass rule max turn deg must be below 180, got {self.max_turn_deg!r}")
        if self.damping_share >= 0.5:
            raise ParameterError(f"pass rule damping share must be below 0.5, got {self.damping_share!r}")
        if self.turn_share > 1.0:
            raise ParameterError(f"pass rule turn share must be at most 1, got {self.turn_share!r}")

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class PassPlan:
    """How one flight's waypoints are flown through.

    Parameters
    ----------
    speed : (n,) float
        m/s at each waypoint; 0 where the drone stops.
    damping_m : (n,) float
        How far before (and after) the waypoint the turn starts; 0 at stops and straight passes
        keep the value the exporter writes.
    offset : (n, 3) float
        Where the drone passes minus the waypoint: 0 at stops.
    leg_seconds : (n - 1,) float
        Time of each leg.
    hover_seconds : (n,) float
        Time hovering at each waypoint (photos taken at a stop).
    """

    speed: np.ndarray
    damping_m: np.ndarray
    offset: np.ndarray
    leg_seconds: np.ndarray
    hover_seconds: np.ndarray

    @property
    def passing(self) -> np.ndarray:
        """(n,) bool: flown through without stopping."""
        return self.speed > 0


def pass_plan(model, positions, shot, heading_deg, pitch_deg, nearest_m, *, pixel_angle: float,
              shutter_s: float, photo_interval_s: float, rules: PassRules = PassRules(),
              stops=None) -> PassPlan:
    """How one flight (take-off at the first waypoint, landing at the last) is flown through.

    Parameters
    ----------
    model : FlightModel
        Speeds, acceleration, rotation rates and the hover at a photo taken at a stop.
    positions : (n, 3) float
    shot : (n,) bool
    heading_deg, pitch_deg : (n,) float
        Transit waypoints face the way they fly, as the planner writes them.
    nearest_m : (n,) float
        At photos: the nearest surface in the frame (the range its blur is judged at).
    pixel_angle : float
        Radians one pixel spans (pixel pitch / focal length).
    shutter_s, photo_interval_s : float
        The exposure and the camera's shortest time between two photos.
    rules : PassRules
    stops : (n,) bool, optional
        Waypoints that must be stops whatever the rules say (a cut corner found unsafe).

    Returns
    -------
    PassPlan
    """
    p = np.asarray(positions, dtype=float).reshape(-1, 3)
    n = len(p)
    shot = np.asarray(shot, dtype=bool)
    zero = np.zeros(n)
    hover = np.where(shot, model.photo_seconds, 0.0)
    if n < 2:
        return PassPlan(zero, zero.copy(), np.zeros((n, 3)), np.zeros(0), hover)
    u, length = _unit(np.diff(p, axis=0))
    theta = np.radians(turn_angles(p))
    before = np.concatenate([[0.0], length])
    after = np.concatenate([length, [0.0]])
    damping = np.minimum(rules.max_damping_m, rules.damping_share * np.minimum(before, after))
    quarter = np.tan(theta / 4.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        damping = np.where(shot & (quarter > 0), np.minimum(damping, rules.max_photo_offset_m / quarter), damping)
    # whole millimetres, rounded down: the route file and the exports then hold exactly the turn judged
    damping = np.floor(damping * 1000.0) / 1000.0
    with np.errstate(divide="ignore", invalid="ignore"):
        radius = np.where(theta > 1e-9, damping / np.tan(np.minimum(theta, np.pi * 0.999) / 2.0), np.inf)
    corner = np.sqrt(model.acceleration * radius)

    top = leg_top_speeds(model, p, heading_deg, pitch_deg, shot, photo_interval_s)
    top_before = np.concatenate([[0.0], top])
    top_after = np.concatenate([top, [0.0]])
    h = np.asarray(heading_deg, dtype=float)
    turn = np.radians(np.abs(heading_change_deg(h[:-1], h[1:]))
                      + np.abs(np.diff(np.asarray(pitch_deg, dtype=float))))
    with np.errstate(divide="ignore", invalid="ignore"):
        per_m = np.where(length > 0, turn / length, 0.0)
    per_m = np.maximum(np.concatenate([[0.0], per_m]), np.concatenate([per_m, [0.0]]))
    near = np.maximum(np.asarray(nearest_m, dtype=float), 1e-3)
    with np.errstate(divide="ignore"):
        blur = rules.max_blur_px * pixel_angle / (shutter_s * (1.0 / near + per_m))
    bound = np.minimum.reduce([corner, top_before, top_after, np.where(shot, blur, np.inf)])
    interior = np.zeros(n, dtype=bool)
    interior[1:-1] = True
    can = interior & (theta <= np.radians(rules.max_turn_deg)) & (damping >= 1e-3)
    if stops is not None:
        can &= ~np.asarray(stops, dtype=bool)
    can &= bound >= rules.min_pass_speed
    bound = np.where(can, bound, 0.0)
    speed = reachable_speeds(bound, length, model.acceleration)
    speed = np.where(can, speed, 0.0)
    legs = _flown_legs(model, length, speed, top, heading_deg, pitch_deg)
    damping = np.where(can, damping, 0.0)
    return PassPlan(speed, damping, corner_offsets(p, damping), legs, np.where(can, 0.0, hover))


def nearest_in_frame(rays, positions, heading_deg, pitch_deg, camera, max_range: float, grid: int = 7) -> np.ndarray:
    """(n,) the nearest surface each photo sees: the shortest of ``grid`` x ``grid`` rays over its
    frame (``max_range`` where none hits).

    Parameters
    ----------
    rays : RayCaster
        The scene's ray caster.
    positions : (n, 3) float
        Camera centres.
    heading_deg, pitch_deg : (n,) float
        Orientations.
    camera : Camera
        The camera.
    max_range : float
        Metres.
    grid : int
        Rays per side of the frame.

    Returns
    -------
    (n,) float
        Metres.
    """
    p = np.asarray(positions, dtype=float).reshape(-1, 3)
    if not len(p):
        return np.zeros(0)
    right, up, forward = camera_axes(heading_deg, pitch_deg)
    s = np.linspace(-1.0, 1.0, grid)
    gx, gy = (a.ravel() for a in np.meshgrid(s * camera.tan_half_hfov, s * camera.tan_half_vfov))
    dirs = forward[:, None, :] + gx[None, :, None] * right[:, None, :] + gy[None, :, None] * up[:, None, :]
    dirs /= np.linalg.norm(dirs, axis=2, keepdims=True)
    origins = np.repeat(p, grid * grid, axis=0)
    dist, _, _ = rays.first_hit(origins, dirs.reshape(-1, 3), max_distance=max_range)
    # a ray's length is not the range along the view axis; the axis depth is what blur scales with
    depth = dist.reshape(len(p), -1) * np.einsum("nkj,nj->nk", dirs, forward)
    return np.minimum(np.where(np.isfinite(depth), depth, max_range).min(axis=1), max_range)


def camera_timing(camera, drone=None, model=None) -> dict:
    """The camera's side of flying through, as :func:`fly_through` takes it: a pixel's angle,
    the exposure and the shortest photo interval (the drone profile's; without one a survey
    exposure and the flight model's photo time).

    Parameters
    ----------
    camera : Camera
        The camera.
    drone : DroneProfile, optional
        The drone.
    model : FlightModel, optional
        The time model.

    Returns
    -------
    dict
        ``pixel_angle`` (radians), ``shutter_s`` and ``photo_interval_s``.
    """
    interval = drone.photo_interval_s if drone is not None else (model.photo_seconds if model is not None else 1.0)
    return {"pixel_angle": camera.pixel_pitch_mm / camera.focal_length_mm,
            "shutter_s": drone.shutter_s if drone is not None else SURVEY_SHUTTER_S,
            "photo_interval_s": interval}


def route_pass_plan(route, model, nearest_m, *, pixel_angle: float, shutter_s: float, photo_interval_s: float,
                    rules: PassRules = PassRules(), stops=None) -> PassPlan:
    """:func:`pass_plan` of every battery flight of ``route``, as route-wide arrays (the leg from
    one flight's landing to the next take-off is not flown: 0 s).

    Parameters
    ----------
    route : Route
        The route.
    model : FlightModel
        The time model.
    nearest_m : (n,) float
        The nearest surface each waypoint's photo sees.
    pixel_angle : float
        Radians per pixel.
    shutter_s : float
        Exposure, seconds.
    photo_interval_s : float
        The shortest time between photos.
    rules : PassRules
        When a waypoint may be flown through.
    stops : (n,) bool, optional
        Waypoints that must be stops.

    Returns
    -------
    PassPlan
        Route-wide arrays.
    """
    n = len(route.positions)
    speed, damping, hover = np.zeros(n), np.zeros(n), np.zeros(n)
    offset, legs = np.zeros((n, 3)), np.zeros(max(n - 1, 0))
    for rows in route.flight_rows():
        plan = pass_plan(model, route.positions[rows], route.shot[rows], route.heading_deg[rows],
                         route.pitch_deg[rows], np.asarray(nearest_m)[rows], pixel_angle=pixel_angle,
                         shutter_s=shutter_s, photo_interval_s=photo_interval_s, rules=rules,
                         stops=None if stops is None else np.asarray(stops)[rows])
        speed[rows], damping[rows], offset[rows], hover[rows] = plan.speed, plan.damping_m, plan.offset, \
            plan.hover_seconds
        legs[rows[:-1]] = plan.leg_seconds
    return PassPlan(speed, damping, offset, legs, hover)


def pass_minutes(route, plan: PassPlan, model) -> list[float]:
    """Minutes of each battery flight of ``route`` flown through by ``plan``, take-off and
    landing included.

    Parameters
    ----------
    route : Route
        The route.
    plan : PassPlan
        Its passes.
    model : FlightModel
        The time model.

    Returns
    -------
    list of float
        Minutes per flight.
    """
    out = []
    for rows in route.flight_rows():
        height = float(route.positions[rows[0], 2] - route.takeoff_z)
        seconds = plan.leg_seconds[rows[:-1]].sum() + plan.hover_seconds[rows].sum() \
            + model.takeoff_landing_seconds(height)
        out.append(float(seconds) / 60.0)
    return out


def fly_through(route, scene, limits, model, *, pixel_angle: float, shutter_s: float, photo_interval_s: float,
                rules: PassRules = PassRules(), max_rounds: int = 4) -> dict:
    """Plan ``route``'s passes in place (``route.pass_speed``, ``route.turn_damping``) and return
    what the summary shows of them.

    The turns it cuts are checked as the final check checks the route: every piece of the
    flown path keeps the security distance and stays out of the zones; a waypoint whose turn
    does not becomes a stop, and the plan is made again.

    Parameters
    ----------
    route : Route
        Changed in place.
    scene : Scene
        The scene.
    limits : ViewLimits
        Altitude band and zones.
    model : FlightModel
        The time model.
    pixel_angle : float
        Radians per pixel.
    shutter_s : float
        Exposure, seconds.
    photo_interval_s : float
        The shortest time between photos.
    rules : PassRules
        When a waypoint may be flown through.
    max_rounds : int
        Times the plan is made again after a turn fails the check.

    Returns
    -------
    dict
        Minutes in total and per flight, and how many waypoints are flown through.
    """
    nearest = np.full(len(route), np.inf)
    shots = route.shots
    reach = 4.0 * max(route.d_opt, route.security)
    nearest[shots] = nearest_in_frame(scene.rays, route.positions[shots], route.heading_deg[shots],
                                      route.pitch_deg[shots], route.camera, reach)
    clearance = scene.clearance_model(limits.security)
    stops = np.zeros(len(route), dtype=bool)
    for _ in range(max_rounds):
        plan = route_pass_plan(route, model, nearest, pixel_angle=pixel_angle, shutter_s=shutter_s,
                               photo_interval_s=photo_interval_s, rules=rules, stops=stops)
        bad = np.zeros(len(route), dtype=bool)
        for rows in route.flight_rows():
            damping = plan.damping_m[rows]
            path, owner = flown_path(route.positions[rows], damping), rows[corner_rows(damping)]
            if len(path) < 2:
                continue
            clear, inside = polyline_checks(path, clearance, limits)
            ok = clear & inside
            bad[owner[:-1][~ok]] = True
            bad[owner[1:][~ok]] = True
        bad &= plan.passing
        if not bad.any():
            break
        stops |= bad
    else:
        plan = route_pass_plan(route, model, nearest, pixel_angle=pixel_angle, shutter_s=shutter_s,
                               photo_interval_s=photo_interval_s, rules=rules, stops=np.ones(len(route), bool))
    route.pass_speed, route.turn_damping = plan.speed, plan.damping_m
    minutes = pass_minutes(route, plan, model)
    in_passing = plan.passing & route.shot
    offsets = np.linalg.norm(plan.offset, axis=1)
    return {"minutes": float(sum(minutes)), "flight_minutes": minutes,
            "photos_in_passing": int(in_passing.sum()), "photos": int(route.shot.sum()),
            "waypoints_flown_through": int(plan.passing.sum()), "corner_stops": int(stops.sum()),
            "max_photo_offset_m": float(offsets[route.shot].max()) if route.shot.any() else 0.0,
            "fastest_photo_mps": float(plan.speed[route.shot].max()) if route.shot.any() else 0.0,
            "rules": rules.to_dict()}
