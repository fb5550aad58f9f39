"""Plans with margin: the planner's rules tightened by the drone's own pose error.

A photo is not taken where the route says: each one is off by the profile's per-photo
position wander and its heading and gimbal error (drones.PositionAccuracy; the flight-wide
part of the error moves every photo alike and changes neither frames nor angles between
them). So the planner judges with what survives the error:

- the frame: a sample counts as imaged only inside a frame shrunk on each side by the heading
  (gimbal pitch) error plus the angle the per-photo wander subtends at the standoff, so that
  it stays in the photo however the drone drifts within one sigma;
- the angles between two photos' rays: the wander of two photos changes them by up to
  atan(sqrt(2) * wander / standoff), so the widest matchable pair is that much narrower
  and the narrowest triangulating pair that much wider.

``margin="none"`` plans with the rules as given (the plans before this module).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from coverplan.equipment.camera import Camera
from coverplan.equipment.drones import DroneProfile, PoseError
from coverplan.errors import ParameterError

MARGINS = ("field", "none")


@dataclass(frozen=True)
class PoseMargin:
    """How much the rules are tightened, in degrees.

    Parameters
    ----------
    frame_h_deg, frame_v_deg : float
        Degrees cut from each side of the frame, horizontally and vertically.
    pair_deg : float
        Degrees taken from the largest matching-pair angle.
    """

    frame_h_deg: float  # taken off each side of the frame, horizontally
    frame_v_deg: float  # and vertically
    pair_deg: float  # off the widest matchable pair, onto the narrowest triangulating one

    def camera(self, camera: Camera) -> Camera:
        """The camera with its frame shrunk (same focal length and pixel pitch: same GSD).

        Parameters
        ----------
        camera : Camera
            The camera asked for.

        Returns
        -------
        Camera
            The narrowed camera.
        """
        if self.frame_h_deg == 0 and self.frame_v_deg == 0:
            return camera
        half_h = math.atan(camera.tan_half_hfov) - math.radians(self.frame_h_deg)
        half_v = math.atan(camera.tan_half_vfov) - math.radians(self.frame_v_deg)
        if half_h <= math.radians(5) or half_v <= math.radians(5):
            raise ParameterError(f"the pose margin ({self.frame_h_deg:.1f} deg, {self.frame_v_deg:.1f} deg) "
                                 f"leaves almost nothing of the {camera.name or 'camera'}'s frame")
        kx = math.tan(half_h) / camera.tan_half_hfov
        ky = math.tan(half_v) / camera.tan_half_vfov
        # Landscape stays landscape: the sensor's width keeps being its long side.
        return Camera(camera.sensor_width_mm * kx, min(camera.sensor_height_mm * ky, camera.sensor_width_mm * kx),
                      camera.focal_length_mm, max(1, int(round(camera.image_width_px * kx))),
                      max(1, int(round(camera.image_height_px * ky))), camera.name)

    def to_dict(self) -> dict:
        return {"frame_h_deg": round(self.frame_h_deg, 3), "frame_v_deg": round(self.frame_v_deg, 3),
                "pair_deg": round(self.pair_deg, 3)}


NO_MARGIN = PoseMargin(0.0, 0.0, 0.0)


def margin_for(kind: str, drone: DroneProfile | None, standoff_m: float) -> PoseMargin:
    """The margin for ``drone`` (a GNSS drone without RTK when None) flying at ``standoff_m``.

    Parameters
    ----------
    kind : {"field", "none"}
    drone : DroneProfile or None
    standoff_m : float
        The planned distance to the surface, metres.

    Returns
    -------
    PoseMargin
        How much the rules are tightened; nothing for ``kind="none"``.
    """
    if kind not in MARGINS:
        raise ParameterError(f"margin must be one of {', '.join(MARGINS)}, got {kind!r}")
    if kind == "none":
        return NO_MARGIN
    error = PoseError.of_drone(drone)
    d = max(float(standoff_m), 1e-3)
    return PoseMargin(frame_h_deg=error.heading_deg + math.degrees(math.atan(error.jitter_h / d)),
                      frame_v_deg=error.pitch_deg + math.degrees(math.atan(error.jitter_v / d)),
                      pair_deg=math.degrees(math.atan(math.sqrt(2.0) * error.jitter_h / d)))


def tightened(match, min_triangulation_deg: float, margin: PoseMargin):
    """(match rule, min triangulation angle) with the margin's pair angle applied.

    Parameters
    ----------
    match : MatchRule or None
        The matching rule.
    min_triangulation_deg : float
        The least triangulation angle asked.
    margin : PoseMargin
        The margin.

    Returns
    -------
    match : MatchRule or None
        With ``max_pair_deg`` lowered by the margin.
    min_triangulation_deg : float
        Raised by the margin.
    """
    tri = float(min_triangulation_deg) + margin.pair_deg
    if match is None or margin.pair_deg == 0:
        return match, tri
    return replace(match, max_pair_deg=match.max_pair_deg - margin.pair_deg), tri
