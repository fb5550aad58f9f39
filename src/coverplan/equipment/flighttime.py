"""How long a flight takes: a waypoint-by-waypoint model a pilot can check by hand.

The drone stops at every waypoint (DJI's "to point and stop", a QGroundControl mission with
hold 0 does nearly the same). Between two waypoints it accelerates at ``acceleration`` up to
the segment's top speed, cruises, and brakes to a stop again: a trapezoidal speed profile, or a
triangular one on legs too short to reach top speed. The top speed keeps the horizontal
component at or below ``cruise_speed`` and the vertical one at or below the climb or descent
rate. On the way the aircraft turns to the next waypoint's heading and the gimbal to its
pitch; a leg takes at least as long as the slower of those rotations. At every photo it
hovers ``photo_seconds`` (settling plus the camera's shortest photo interval). Each flight
adds take-off (motors, climb to the start point's height) and landing (descent from it).

docs/flights.md states every term and compares the model with the simple estimate.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from coverplan.errors import ParameterError
from coverplan.geometry.orientation import heading_change_deg


@dataclass(frozen=True)
class FlightModel:
    """How long a flight takes: speeds, acceleration and turn rates of a drone flying stop to stop.

    Parameters
    ----------
    cruise_speed : float
        Horizontal speed between waypoints, m/s.
    acceleration : float
        m/s², speeding up and braking alike.
    ascent_speed, descent_speed : float
        m/s.
    yaw_rate_deg, gimbal_rate_deg : float
        Degrees per second.
    photo_seconds : float
        Hover at each photo.
    takeoff_seconds : float
        Motors on to lifting off, and after landing to motors off.
    landing_speed : float
        The last descent to the ground, m/s.
    """
    cruise_speed: float = 5.0  # m/s, horizontal, between waypoints
    acceleration: float = 2.0  # m/s², speeding up and braking alike
    ascent_speed: float = 3.0  # m/s
    descent_speed: float = 2.0  # m/s
    yaw_rate_deg: float = 60.0  # deg/s, aircraft heading
    gimbal_rate_deg: float = 60.0  # deg/s, gimbal pitch
    photo_seconds: float = 1.0  # hover at each photo
    takeoff_seconds: float = 10.0  # motors on to lifting off, and after landing to motors off
    landing_speed: float = 1.5  # m/s, the last descent to the ground is slower than cruise descent

    def __post_init__(self):
        for name, value in asdict(self).items():
            if not (np.isfinite(value) and (value > 0 or name in ("photo_seconds", "takeoff_seconds") and value >= 0)):
                raise ParameterError(f"flight model {name.replace('_', ' ')} must be a positive number, got {value!r}")

    def to_dict(self) -> dict:
        return asdict(self)

    def top_speeds(self, a, b) -> np.ndarray:
        """(n,) the highest speed from each point of ``a`` to the matching point of ``b`` whose
        horizontal part is within the cruise speed and vertical part within the climb or
        descent rate (the cruise speed for an empty segment).

        Parameters
        ----------
        a, b : (n, 3) float
            Segment ends.

        Returns
        -------
        (n,) float
            m/s.
        """
        d = np.asarray(b, dtype=float).reshape(-1, 3) - np.asarray(a, dtype=float).reshape(-1, 3)
        length = np.linalg.norm(d, axis=1)
        horizontal = np.hypot(d[:, 0], d[:, 1])
        vertical = np.abs(d[:, 2])
        rate = np.where(d[:, 2] > 0, self.ascent_speed, self.descent_speed)
        with np.errstate(divide="ignore", invalid="ignore"):
            top = np.minimum(np.where(horizontal > 0, self.cruise_speed * length / horizontal, np.inf),
                             np.where(vertical > 0, rate * length / vertical, np.inf))
        return np.where(np.isfinite(top), top, self.cruise_speed)

    def segment_seconds(self, a, b) -> np.ndarray:
        """Travel time from rest at each point of ``a`` to rest at the matching point of ``b``.

        Parameters
        ----------
        a, b : (n, 3) float
            Segment ends.

        Returns
        -------
        (n,) float
            Seconds.
        """
        length = np.linalg.norm(np.asarray(b, dtype=float).reshape(-1, 3) - np.asarray(a, dtype=float).reshape(-1, 3),
                                axis=1)
        top = self.top_speeds(a, b)
        reaches_top = length >= top ** 2 / self.acceleration
        return np.where(reaches_top, length / np.maximum(top, 1e-12) + top / self.acceleration,
                        2.0 * np.sqrt(length / self.acceleration))

    def rotation_seconds(self, heading_deg, pitch_deg) -> np.ndarray:
        """Per waypoint after the first: time to turn from the previous heading and pitch.

        Parameters
        ----------
        heading_deg, pitch_deg : (n,) float
            Each waypoint's orientation.

        Returns
        -------
        (n - 1,) float
            Seconds.
        """
        h = np.asarray(heading_deg, dtype=float)
        turn = np.abs(heading_change_deg(h[:-1], h[1:]))
        tilt = np.abs(np.diff(np.asarray(pitch_deg, dtype=float)))
        return np.maximum(turn / self.yaw_rate_deg, tilt / self.gimbal_rate_deg)

    def takeoff_landing_seconds(self, height_m: float) -> float:
        """Take-off to ``height_m`` above the ground and landing from there.

        Parameters
        ----------
        height_m : float
            The first waypoint's height above the ground.

        Returns
        -------
        float
            Seconds.
        """
        h = max(float(height_m), 0.0)
        return 2.0 * self.takeoff_seconds + h / self.ascent_speed + h / self.landing_speed

    def flight_seconds(self, positions, shot, heading_deg, pitch_deg, height_m: float) -> dict:
        """Time of one flight through ``positions`` (take-off at the first, landing at the last),
        as parts that add up to ``total``.

        Parameters
        ----------
        positions : (n, 3) float
            Waypoints.
        shot : (n,) bool
            Which take a photo.
        heading_deg, pitch_deg : (n,) float
            Orientations.
        height_m : float
            The take-off height above the ground.

        Returns
        -------
        dict
            Seconds per part (travel, turns, photos, take-off and landing) and ``total_s``.
        """
        p = np.asarray(positions, dtype=float).reshape(-1, 3)
        travel = self.segment_seconds(p[:-1], p[1:]) if len(p) > 1 else np.zeros(0)
        turn = self.rotation_seconds(heading_deg, pitch_deg) if len(p) > 1 else np.zeros(0)
        legs = np.maximum(travel, turn)
        photos = float(np.count_nonzero(shot)) * self.photo_seconds
        ground = self.takeoff_landing_seconds(height_m)
        parts = {"travel_s": float(travel.sum()), "rotation_wait_s": float((legs - travel).sum()),
                 "photos_s": photos, "takeoff_landing_s": ground}
        parts["total_s"] = sum(parts.values())
        return parts


def leg_seconds(model: FlightModel, points, heading_from: float, heading_to: float,
                pitch_from: float, pitch_to: float) -> float:
    """Time along a polyline that stops at each point, turning from one orientation to another
    (transit points in between face the way they fly, as the planner writes them; a NaN
    ``heading_from`` faces the first step).

    Parameters
    ----------
    model : FlightModel
        The time model.
    points : (n, 3) float
        The polyline.
    heading_from, heading_to : float
        Degrees at its ends.
    pitch_from, pitch_to : float
        Degrees at its ends.

    Returns
    -------
    float
        Seconds.
    """
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    if len(p) < 2:
        return float(model.rotation_seconds([heading_from, heading_to], [pitch_from, pitch_to])[0]) \
            if np.isfinite(heading_from) else 0.0
    step = np.diff(p, axis=0)
    travel_heading = np.degrees(np.arctan2(step[:, 0], step[:, 1]))
    if not np.isfinite(heading_from):  # leaving the take-off point: it faces the way it flies
        heading_from = travel_heading[0]
    headings = np.concatenate([[heading_from], travel_heading[1:], [heading_to]])
    pitches = np.concatenate([[pitch_from], np.zeros(len(p) - 2), [pitch_to]])
    return float(np.maximum(model.segment_seconds(p[:-1], p[1:]), model.rotation_seconds(headings, pitches)).sum())
