"""Drone profiles: the camera, gimbal, speeds, battery and mission limits of drones people fly.

Facts are from the makers' published specifications, named beside each value; values that
are our own working assumptions (acceleration, rotation rates, the battery reserve) say so.
Rated flight times are hover or best-speed figures without wind down to an empty battery;
``usable_flight_min`` keeps ``reserve`` of that for wind, the return and a landing with charge
left, and is the default length of one flight (``--max-flight-min``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from coverplan.equipment.camera import PRESETS, Camera
from coverplan.equipment.flighttime import FlightModel
from coverplan.equipment.lens import PINHOLE, Lens
from coverplan.errors import ParameterError

RESERVE = 0.30  # of the rated flight time; DJI apps warn at 30 % battery by default
# Exposure time a survey photo takes in daylight: our working assumption (mapping guides ask
# for 1/500 s or shorter to keep blur below a pixel); the makers give only the shutter's range.
SURVEY_SHUTTER_S = 1.0 / 500.0


@dataclass(frozen=True)
class PositionAccuracy:
    """How far from the commanded point the drone really is, as the maker's hover accuracy
    bounds (metres, +-) for the positioning it flies with (``source``: "gnss" or "rtk").

    Parameters
    ----------
    horizontal_m, vertical_m : float
        Hover accuracy bounds, metres.
    source : {"gnss", "rtk"}
        The positioning they hold for.
    """

    horizontal_m: float
    vertical_m: float
    source: str = "gnss"

    def __post_init__(self):
        for name in ("horizontal_m", "vertical_m"):
            v = float(getattr(self, name))
            if not v >= 0.0:
                raise ParameterError(f"position accuracy {name} must be >= 0, got {v!r}")
        if self.source not in ("gnss", "rtk"):
            raise ParameterError(f"position source must be gnss or rtk, got {self.source!r}")

    # The "+-" bound read as about 1.5 sigma of an error common to the whole flight that drifts
    # slowly, plus a per-photo wander of 0.2 of the bound (the Phantom 4 Pro's +-1.5 m: a
    # flight-wide N(0, 1 m) and N(0, 0.3 m) per photo). RTK has no slow bias to speak of: a
    # third of the bound each.
    @property
    def bias_sigma(self) -> tuple[float, float]:
        """1-sigma (horizontal per axis, vertical) of the flight-wide error, metres."""
        f = 1.0 / 1.5 if self.source == "gnss" else 1.0 / 3.0
        return f * self.horizontal_m, f * self.vertical_m

    @property
    def jitter_sigma(self) -> tuple[float, float]:
        """1-sigma (horizontal per axis, vertical) of each photo's own error, metres."""
        f = 0.2 if self.source == "gnss" else 1.0 / 3.0
        return f * self.horizontal_m, f * self.vertical_m


# A GNSS drone without RTK as most are flown: the Phantom 4 Pro's published bounds. Used where
# a route names no drone profile.
TYPICAL_GNSS = PositionAccuracy(1.5, 0.5, "gnss")
HEADING_ERROR_DEG = 1.5  # 1 sigma, compass/IMU heading: assumption (no maker figure)
GIMBAL_ERROR_DEG = 0.5  # 1 sigma, gimbal pitch: assumption (makers give +-0.01 deg control)


@dataclass(frozen=True)
class DroneProfile:
    """A drone as the planner, the flight-time model and the exports see it.

    Parameters
    ----------
    name : str
        The profile's key (``--drone NAME``).
    label : str
        The maker's name of the model.
    camera : Camera
        Its camera.
    gimbal_pitch_deg : (float, float)
        Lowest and highest pitch the planner may use.
    max_speed : float
        m/s.
    ascent_speed, descent_speed : float
        Maximum vertical speeds, m/s.
    rated_flight_min : float
        The maker's flight time on one battery.
    photo_interval_s : float
        The shortest time between two photos.
    apps : tuple of str
        Export formats of the apps that fly it.
    wpml : (int, int, int), optional
        DJI WPML droneEnumValue, droneSubEnumValue and payloadEnumValue.
    image_format : str
        WPML payloadParam imageFormat.
    cruise_speed : float
        m/s between waypoints near a building (a default, not a limit).
    acceleration : float
        m/s², speeding up and braking.
    yaw_rate_deg, gimbal_rate_deg : float
        Degrees per second.
    sources : tuple of str
        Where the figures come from.
    reserve : float
        The share of the battery kept in reserve.
    position : PositionAccuracy
        Hover accuracy of the positioning flown with.
    heading_error_deg, gimbal_error_deg : float
        1-sigma heading and gimbal pitch error.
    shutter_s : float
        The exposure time of a survey photo.
    lens : Lens
        The distortion of its photos as the camera writes them.
    """
    name: str
    label: str
    camera: Camera
    gimbal_pitch_deg: tuple[float, float]  # lowest, highest pitch the planner may use
    max_speed: float  # m/s
    ascent_speed: float  # m/s, maximum
    descent_speed: float  # m/s, maximum
    rated_flight_min: float
    photo_interval_s: float  # shortest time between two photos
    apps: tuple[str, ...]  # export formats of the apps that fly it
    wpml: tuple[int, int, int] | None = None  # DJI WPML droneEnumValue, droneSubEnumValue, payloadEnumValue
    image_format: str = "wide"  # WPML payloadParam imageFormat
    cruise_speed: float = 5.0  # m/s between waypoints near a building: our default, not a limit
    acceleration: float = 2.0  # m/s²: assumption, gentle for photo stops
    yaw_rate_deg: float = 60.0  # deg/s: assumption
    gimbal_rate_deg: float = 60.0  # deg/s: assumption
    sources: tuple[str, ...] = field(default_factory=tuple)
    reserve: float = RESERVE
    position: PositionAccuracy = TYPICAL_GNSS  # hover accuracy of the positioning flown with
    heading_error_deg: float = HEADING_ERROR_DEG
    gimbal_error_deg: float = GIMBAL_ERROR_DEG
    shutter_s: float = SURVEY_SHUTTER_S
    lens: Lens = PINHOLE  # the distortion of its photos as the camera writes them (simulate --lens drone)

    @property
    def usable_flight_min(self) -> float:
        """Minutes of one battery flight after the reserve."""
        return round(self.rated_flight_min * (1.0 - self.reserve), 1)

    def flight_model(self, cruise_speed: float | None = None) -> FlightModel:
        """The time model for this drone; ``cruise_speed`` (m/s) overrides the default.

        Parameters
        ----------
        cruise_speed : float, optional
            m/s.

        Returns
        -------
        FlightModel
            Its speeds, acceleration and rates.
        """
        speed = self.cruise_speed if cruise_speed is None else float(cruise_speed)
        if not 0 < speed <= self.max_speed:
            raise ParameterError(f"speed {speed:g} m/s is outside what the {self.label} flies (0, {self.max_speed:g}]")
        return FlightModel(cruise_speed=speed, acceleration=self.acceleration,
                           ascent_speed=min(self.ascent_speed, 3.0), descent_speed=min(self.descent_speed, 2.0),
                           yaw_rate_deg=self.yaw_rate_deg, gimbal_rate_deg=self.gimbal_rate_deg,
                           photo_seconds=max(self.photo_interval_s, 1.0))


DRONES: dict[str, DroneProfile] = {
    "m3e": DroneProfile(
        name="m3e", label="DJI Mavic 3 Enterprise", camera=PRESETS["mavic3e"],
        # Gimbal tilt -90 to +35 deg, max horizontal speed 15 m/s (normal mode), ascent 6 m/s,
        # descent 6 m/s, max flight time 45 min, mechanical shutter, JPEG interval 0.7 s:
        # DJI Mavic 3 Enterprise specifications (enterprise.dji.com/mavic-3-enterprise/specs).
        gimbal_pitch_deg=(-90.0, 35.0), max_speed=15.0, ascent_speed=6.0, descent_speed=6.0,
        rated_flight_min=45.0, photo_interval_s=0.7, apps=("wpml",),
        # droneEnumValue 77 / sub 0 (M3E), payloadEnumValue 66 (Mavic 3E camera): DJI WPML
        # common elements, droneInfo and payloadInfo.
        wpml=(77, 0, 66), image_format="wide",
        # Hovering accuracy +-0.5 m horizontal, +-0.5 m vertical with GNSS (the RTK module is an
        # option): DJI Mavic 3 Enterprise specifications.
        position=PositionAccuracy(0.5, 0.5, "gnss"),
        sources=("DJI Mavic 3 Enterprise specifications", "DJI WPML common elements")),
    "m4e": DroneProfile(
        name="m4e", label="DJI Matrice 4E", camera=PRESETS["matrice4e"],
        # Wide camera gimbal tilt -90 to +35 deg, max horizontal speed 21 m/s, ascent 10 m/s,
        # descent 8 m/s, max flight time 49 min, mechanical shutter, shortest photo interval
        # 0.5 s: DJI Matrice 4E specifications, as published at launch (January 2025).
        gimbal_pitch_deg=(-90.0, 35.0), max_speed=21.0, ascent_speed=10.0, descent_speed=8.0,
        rated_flight_min=49.0, photo_interval_s=0.5, apps=("wpml",),
        # droneEnumValue 99 / sub 0 (M4E), payloadEnumValue 88 (M4E camera): DJI Cloud API
        # product support.
        wpml=(99, 0, 88), image_format="visible",
        # Hovering accuracy +-0.5 m horizontal (high-precision positioning) and +-0.5 m
        # vertical with GNSS, +-0.1 m with RTK (an option): DJI Matrice 4E specifications.
        position=PositionAccuracy(0.5, 0.5, "gnss"),
        sources=("DJI Matrice 4E specifications", "DJI Cloud API product support")),
    "m350-p1": DroneProfile(
        name="m350-p1", label="DJI Matrice 350 RTK with Zenmuse P1 (35 mm)", camera=PRESETS["zenmuse-p1-35"],
        # M350 RTK: max horizontal speed 23 m/s, ascent 6 m/s, descent 5 m/s, max flight time
        # 55 min without payload (DJI Matrice 350 RTK specifications). With the P1 (about 0.8 kg)
        # we assume 45 min: our estimate, not a published figure; override with --max-flight-min. P1 gimbal tilt
        # -125 to +40 deg mechanical; planned within -90 to +30. Photo interval 0.7 s (DJI
        # Zenmuse P1 specifications).
        gimbal_pitch_deg=(-90.0, 30.0), max_speed=23.0, ascent_speed=6.0, descent_speed=5.0,
        rated_flight_min=45.0, photo_interval_s=0.7, apps=("wpml",),
        # droneEnumValue 89 (M350 RTK): DJI WPML common elements. payloadEnumValue 50 (Zenmuse
        # P1): DJI Cloud API product support, payload enumeration (the WPML table lists only the
        # H20/H30/M3 cameras).
        wpml=(89, 0, 50), image_format="visible",
        # RTK built in: hovering accuracy +-0.1 m horizontal and vertical with RTK (+-1.5 m /
        # +-0.5 m with GNSS alone): DJI Matrice 350 RTK specifications.
        position=PositionAccuracy(0.1, 0.1, "rtk"),
        sources=("DJI Matrice 350 RTK specifications", "DJI Zenmuse P1 specifications",
                 "DJI WPML common elements", "DJI Cloud API product support")),
    "phantom4pro": DroneProfile(
        name="phantom4pro", label="DJI Phantom 4 Pro V2.0", camera=PRESETS["phantom4pro"],
        # Gimbal pitch -90 to +30 deg, max speed 14 m/s (P-mode), ascent 5 m/s and descent
        # 3 m/s (P-mode), max flight time 30 min, shortest JPEG interval 2 s: DJI Phantom 4 Pro
        # V2.0 specifications. Flown with Litchi.
        gimbal_pitch_deg=(-90.0, 30.0), max_speed=14.0, ascent_speed=5.0, descent_speed=3.0,
        rated_flight_min=30.0, photo_interval_s=2.0, apps=("litchi",),
        # Hover accuracy +-1.5 m horizontal, +-0.5 m vertical with GPS: DJI Phantom 4 Pro V2.0
        # specifications.
        position=PositionAccuracy(1.5, 0.5, "gnss"),
        # The 1" 20 MP camera's raw lens with in-camera correction off, as a Phantom 4 RTK (the
        # same camera and lens) records it in every photo's DewarpData XMP tag: strong barrel,
        # about 14 % at the corners. DJI publishes no figure for the Pro itself.
        lens=Lens(-0.269478, 0.115681, -0.0000875619, -0.000306177, -0.0357628,
                  source="DewarpData of a Phantom 4 RTK photo"),
        sources=("DJI Phantom 4 Pro V2.0 specifications", "Litchi mission hub documentation")),
}

def get_drone(name: str) -> DroneProfile:
    """The profile called ``name``; the error lists the profiles that exist.

    Parameters
    ----------
    name : str
        A profile's key, any case.

    Returns
    -------
    DroneProfile
        The profile.

    Raises
    ------
    ParameterError
        When no profile has that name.
    """
    try:
        return DRONES[name.lower()]
    except KeyError:
        raise ParameterError(f"unknown drone {name!r}; drones: {', '.join(sorted(DRONES))} "
                             "(see 'coverplan drones')") from None


@dataclass(frozen=True)
class PoseError:
    """A drone's own pose error as 1-sigma values: the flight-wide position bias and the
    per-photo wander (metres, horizontal per axis and vertical), heading and gimbal pitch (deg).

    Parameters
    ----------
    bias_h, bias_v : float
        Flight-wide position bias, metres (horizontal per axis, vertical).
    jitter_h, jitter_v : float
        Per-photo wander, metres.
    heading_deg, pitch_deg : float
        Heading and gimbal pitch error, degrees.
    """

    bias_h: float
    bias_v: float
    jitter_h: float
    jitter_v: float
    heading_deg: float
    pitch_deg: float

    @classmethod
    def of_drone(cls, drone: "DroneProfile | None") -> "PoseError":
        """The profile's error, or a GNSS drone's without RTK (TYPICAL_GNSS) when None.

        Parameters
        ----------
        drone : DroneProfile or None
            The drone flown.

        Returns
        -------
        PoseError
            Its 1-sigma errors.
        """
        accuracy = drone.position if drone is not None else TYPICAL_GNSS
        (bh, bv), (jh, jv) = accuracy.bias_sigma, accuracy.jitter_sigma
        if drone is None:
            return cls(bh, bv, jh, jv, HEADING_ERROR_DEG, GIMBAL_ERROR_DEG)
        return cls(bh, bv, jh, jv, float(drone.heading_error_deg), float(drone.gimbal_error_deg))


POSITION_MARGIN_M = 1.0  # beyond the hover accuracy bound: gusts, the model's own error (assumption)


def security_shortfall(security: float, drone: "DroneProfile | None") -> str | None:
    """Why ``security`` is too small for the drone's own position error, or None.

    The security distance is the drone's only protection against its position error, so it
    should be at least the horizontal hover accuracy bound plus POSITION_MARGIN_M. Without a
    profile, a GNSS drone without RTK (TYPICAL_GNSS) is assumed.

    Parameters
    ----------
    security : float
        The security distance, metres.
    drone : DroneProfile or None
        The drone flown.

    Returns
    -------
    str or None
        The reason, naming the distance that would do.
    """
    acc = drone.position if drone is not None else TYPICAL_GNSS
    need = acc.horizontal_m + POSITION_MARGIN_M
    if float(security) >= need - 1e-9:
        return None
    who = f"the {drone.label}'s" if drone is not None else "a GNSS drone's (no --drone given)"
    return (f"security {float(security):g} m is less than {who} horizontal position error "
            f"+-{acc.horizontal_m:g} m ({acc.source.upper()}) plus a {POSITION_MARGIN_M:g} m margin = {need:g} m")


def drone_of_route(route) -> DroneProfile | None:
    """The profile a route was planned with (its ``params["drone"]``), if any.

    Parameters
    ----------
    route : Route
        A planned route.

    Returns
    -------
    DroneProfile or None
        The profile.
    """
    name = route.params.get("drone")
    return DRONES.get(str(name).lower()) if name else None


def with_gimbal(drone: DroneProfile, lowest: float, highest: float) -> DroneProfile:
    """The profile with another gimbal range (a gimbal that cannot look up, say).

    Parameters
    ----------
    drone : DroneProfile
        The profile.
    lowest, highest : float
        Degrees.

    Returns
    -------
    DroneProfile
        A new profile.
    """
    return replace(drone, gimbal_pitch_deg=(float(lowest), float(highest)))


def drones_table() -> str:
    """The profiles as a terminal table (``coverplan drones``).

    Returns
    -------
    str
        One line per profile under a header.
    """
    rows = [("name", "drone", "camera", "gimbal deg", "speed m/s", "flight min", "photo s", "position", "apps")]
    for d in DRONES.values():
        rows.append((d.name, d.label, d.camera.name or "", f"{d.gimbal_pitch_deg[0]:g}..{d.gimbal_pitch_deg[1]:+g}",
                     f"{d.cruise_speed:g} (max {d.max_speed:g})",
                     f"{d.usable_flight_min:g} of {d.rated_flight_min:g}", f"{d.photo_interval_s:g}",
                     f"+-{d.position.horizontal_m:g}/{d.position.vertical_m:g} m {d.position.source.upper()}",
                     ", ".join(d.apps)))
    widths = [max(len(r[k]) for r in rows) for k in range(len(rows[0]))]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows)
