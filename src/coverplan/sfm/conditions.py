"""Where and how a real drone takes a route's photos: the field conditions of ``simulate``.

A route says where each photo should be taken. A drone flying it with GNSS is somewhere else:
a position error common to the whole flight that drifts slowly (the satellites' geometry and
the atmosphere change over minutes) plus a per-photo wander of the hover, a heading and a
gimbal pitch a little off, a residual motion during the exposure. The light changes too: the
sun moves, clouds pass, and the camera's auto exposure answers each photo differently.

``fly`` draws one such flight; ``simulate`` renders the photos from the drawn poses and judges
the reconstruction against the true scene (aligned to where the photos were really taken, as
a survey with ground control points would be). docs/reconstruction.md states every number.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from coverplan.equipment.drones import (
    SURVEY_SHUTTER_S,
    DroneProfile,
    PoseError,
    drone_of_route,
)
from coverplan.equipment.flighttime import FlightModel
from coverplan.errors import ParameterError
from coverplan.flight.corners import travel_directions
from coverplan.flight.speeds import route_leg_seconds
from coverplan.sfm.field_render import check_metering
from coverplan.sfm.render import _SUN as FIXED_SUN

BIAS_CORRELATION_S = 300.0  # the flight-wide error's drift: correlated over about 5 minutes
BATTERY_SWAP_S = 300.0  # between two battery flights
HOVER_SPEED_SIGMA = 0.15  # m/s per horizontal axis, a hovering drone's residual motion: assumption
SUN_DEG_PER_S = 15.0 / 3600.0  # the sun's azimuth moves 15 deg an hour
CLOUD_CORRELATION_S = 120.0  # passing clouds dim the direct sun over about 2 minutes


@dataclass(frozen=True)
class Conditions:
    """What the rendered photos suffer; ``ideal``, ``field`` and ``harsh`` are the presets.

    Parameters
    ----------
    name : str
        The preset's name.
    pose_error : bool
        GNSS/RTK position, heading and gimbal error.
    light : bool
        Moving sun with cast shadows, clouds, auto exposure, sensor noise, motion blur.
    facades : bool
        Real façade materials: plaster, brick, window grids, glass, roof tiles.
    metering : {"center", "average"}
        The camera's auto exposure.
    """

    name: str
    pose_error: bool  # GNSS/RTK position, heading and gimbal error
    light: bool  # moving sun with cast shadows, clouds, auto exposure, sensor noise, motion blur
    facades: bool  # real façade materials: plaster, brick, window grids, glass, roof tiles
    metering: str = "center"  # the camera's auto exposure: "center" (DJI's default) or "average"

    def __post_init__(self):
        check_metering(self.metering)

    @property
    def physical_textures(self) -> bool:
        """Textures at the materials' own scales (not tuned to the flight's range)."""
        return self.pose_error or self.light or self.facades


CONDITIONS = {
    "ideal": Conditions("ideal", pose_error=False, light=False, facades=False),
    "field": Conditions("field", pose_error=True, light=True, facades=False),
    "harsh": Conditions("harsh", pose_error=True, light=True, facades=True),
}


def get_conditions(name: str) -> Conditions:
    """The field conditions called ``name``.

    Parameters
    ----------
    name : str
        One of ``CONDITIONS`` (any case).

    Returns
    -------
    Conditions

    Raises
    ------
    ParameterError
        Any other name.
    """
    try:
        return CONDITIONS[str(name).lower()]
    except KeyError:
        raise ParameterError(f"unknown conditions {name!r}; choose one of {', '.join(CONDITIONS)}") from None


@dataclass
class FlownPhotos:
    """One draw of a flight: for every photo, the pose it was really taken from and its light.

    Parameters
    ----------
    positions : (n, 3) float
        Where the camera really was.
    heading_deg, pitch_deg : (n,) float
        Its orientation.
    time_s : (n,) float
        Since the first take-off.
    velocity : (n, 3) float
        m/s during the exposure.
    sun : (n, 3) float
        Unit vectors towards the sun.
    direct : (n,) float
        Direct sunlight, 1 clear sky, 0 overcast.
    exposure : (n,) float
        The camera's gain relative to a metered exposure.
    shutter_s : float
        Exposure time.
    seed : int
        The draw's seed.
    planned : (n, 3) float
        The route's positions.
    recorded : (n, 3) float
        The photos' GNSS tags.
    """

    positions: np.ndarray  # (n, 3) where the camera really was
    heading_deg: np.ndarray  # (n,)
    pitch_deg: np.ndarray  # (n,)
    time_s: np.ndarray  # (n,) since the first take-off
    velocity: np.ndarray  # (n, 3) m/s during the exposure
    sun: np.ndarray  # (n, 3) unit vector towards the sun
    direct: np.ndarray  # (n,) direct sunlight, 1 = clear sky, 0 = overcast
    exposure: np.ndarray  # (n,) the camera's gain relative to a metered exposure
    shutter_s: float
    seed: int
    planned: np.ndarray = field(repr=False, default=None)  # (n, 3) the route's positions
    recorded: np.ndarray = field(repr=False, default=None)  # (n, 3) the photos' GNSS tags: true minus the bias

    @property
    def offset_m(self) -> np.ndarray:
        """(n,) distance from each photo's planned position."""
        return np.linalg.norm(self.positions - self.planned, axis=1)


def photo_times(route, model: FlightModel, photo_interval_s: float | None = None) -> np.ndarray:
    """Seconds from the first take-off at each of the route's photos (battery swaps included),
    through the route's pass speeds where it flies through.

    Parameters
    ----------
    route : Route
        The flight (n waypoints).
    model : FlightModel
        The drone's flight-time model.
    photo_interval_s : float, optional
        Least time between photos in passing, s (default: the model's).

    Returns
    -------
    (n,) float
        Seconds at each waypoint.
    """
    p = route.positions
    legs = np.zeros(len(p))
    if len(p) > 1:
        if route.flies_through:
            interval = model.photo_seconds if photo_interval_s is None else photo_interval_s
            legs[1:] = route_leg_seconds(route, model, interval)
        else:
            legs[1:] = np.maximum(model.segment_seconds(p[:-1], p[1:]),
                                  model.rotation_seconds(route.heading_deg, route.pitch_deg))
        new_flight = np.flatnonzero(np.diff(route.flight) != 0) + 1
        legs[new_flight] = BATTERY_SWAP_S
    photo = np.where(route.shot & ~route.passing(), model.photo_seconds, 0.0)
    t = np.cumsum(legs + photo) - photo  # the photo is taken on arrival, after settling
    return t[route.shots]


def _drift(rng, t: np.ndarray, sigma: float, tau: float, dims: int) -> np.ndarray:
    """An Ornstein-Uhlenbeck process (stationary sigma, correlation time tau) sampled at t."""
    out = np.zeros((len(t), dims))
    if len(t) == 0 or sigma == 0:
        return out
    out[0] = rng.normal(0.0, sigma, dims)
    keep = np.exp(-np.diff(t) / tau)
    fresh = rng.normal(0.0, 1.0, (len(t) - 1, dims)) * (sigma * np.sqrt(1.0 - keep ** 2))[:, None]
    for k in range(1, len(t)):  # a recurrence over photos (hundreds), not over rays or pixels
        out[k] = keep[k - 1] * out[k - 1] + fresh[k - 1]
    return out


def fly(route, conditions: Conditions, seed: int = 0, drone: DroneProfile | None = None,
        error: PoseError | None = None) -> FlownPhotos:
    """Draw where the drone really takes each of the route's photos, and in what light.

    Parameters
    ----------
    route : Route
        The planned flight; its ``params["drone"]`` names the profile unless ``drone`` is given.
    conditions : Conditions
        ``ideal`` returns the planned poses in a fixed light.
    seed : int
        One seed, one draw.
    drone : DroneProfile, optional
        The drone flown; the route's profile when None.
    error : PoseError, optional
        Overrides the profile's position, heading and gimbal error.

    Returns
    -------
    FlownPhotos
        Per photo, in the route's shot order.
    """
    drone = drone if drone is not None else drone_of_route(route)
    error = error if error is not None else PoseError.of_drone(drone)
    shots = route.shots
    n = len(shots)
    rng = np.random.default_rng([int(seed), 0x5EED])
    model = drone.flight_model() if drone is not None else FlightModel()
    t = photo_times(route, model, drone.photo_interval_s if drone is not None else None)
    planned = route.flown_positions()[shots]  # flying through, the drone passes off the planned point
    positions, heading, pitch = planned.copy(), route.heading_deg[shots].copy(), route.pitch_deg[shots].copy()
    recorded = planned.copy()
    if conditions.pose_error:
        bias = _drift(rng, t, 1.0, BIAS_CORRELATION_S, 3) * [error.bias_h, error.bias_h, error.bias_v]
        jitter = rng.normal(0.0, 1.0, (n, 3)) * [error.jitter_h, error.jitter_h, error.jitter_v]
        positions = planned + bias + jitter
        recorded = planned + jitter  # the receiver does not see its own bias
        heading = np.mod(heading + rng.normal(0.0, error.heading_deg, n), 360.0)
        pitch = pitch + rng.normal(0.0, error.pitch_deg, n)
    # The sun: somewhere between mid-morning and mid-afternoon, moving with the clock. Drawn
    # from the seed alone, so that two flights of a scene drawn with one seed fly under the
    # same sun whatever their photo counts (with the main stream the chapel's 104- and
    # 115-photo plans met suns 90-250 deg apart, which decides the faces in shade).
    light = np.random.default_rng([int(seed), 0x50A1])
    azimuth0, elevation = light.uniform(0.0, 360.0), light.uniform(30.0, 60.0)
    if conditions.light:
        az = np.radians(azimuth0 + SUN_DEG_PER_S * t)
        el = np.radians(elevation)
        sun = np.column_stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.full(n, np.sin(el))])
        cloud = _drift(rng, t, 1.0, CLOUD_CORRELATION_S, 1)[:, 0]
        direct = np.clip(0.75 + 0.35 * cloud, 0.15, 1.0)  # mostly sunny, clouds now and then
        exposure = np.exp(rng.normal(0.0, 0.1, n))  # auto exposure meters each photo anew
        velocity = np.column_stack([rng.normal(0.0, HOVER_SPEED_SIGMA, (n, 2)), rng.normal(0.0, 0.05, n)])
        if route.flies_through:  # photos taken in passing move at the pass speed along the path
            velocity = velocity + (route.pass_speed[:, None] * travel_directions(route.positions))[shots]
    else:
        sun = np.tile(FIXED_SUN, (n, 1))
        direct, exposure, velocity = np.ones(n), np.ones(n), np.zeros((n, 3))
    shutter = drone.shutter_s if drone is not None else SURVEY_SHUTTER_S
    return FlownPhotos(positions, heading, pitch, t, velocity, sun, direct, exposure, shutter, int(seed), planned,
                       recorded)
