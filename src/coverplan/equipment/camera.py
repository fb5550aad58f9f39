"""Pinhole camera model, presets, and the GSD <-> distance relations of docs/design.md."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from coverplan.errors import ParameterError


@dataclass(frozen=True)
class Camera:
    """A camera by its sensor (mm), focal length (mm) and image size (px).

    Images are landscape: the sensor's long side is horizontal.

    Parameters
    ----------
    sensor_width_mm, sensor_height_mm : float
        The sensor's size in mm.
    focal_length_mm : float
        The lens's real focal length in mm (not the 35 mm equivalent).
    image_width_px, image_height_px : int
        The photo's size in pixels.
    name : str, optional
        The preset's name.
    """

    sensor_width_mm: float
    sensor_height_mm: float
    focal_length_mm: float
    image_width_px: int
    image_height_px: int
    name: str | None = None

    def __post_init__(self):
        for field in ("sensor_width_mm", "sensor_height_mm", "focal_length_mm",
                      "image_width_px", "image_height_px"):
            value = getattr(self, field)
            try:
                ok = math.isfinite(float(value)) and float(value) > 0
            except (TypeError, ValueError):
                ok = False
            if not ok:
                raise ParameterError(f"camera {field} must be a positive number, got {value!r}")
        for field in ("image_width_px", "image_height_px"):
            value = float(getattr(self, field))
            if value != int(value):
                raise ParameterError(f"camera {field} must be a whole number of pixels, got {value!r}")
            object.__setattr__(self, field, int(value))
        if self.sensor_width_mm < self.sensor_height_mm:
            raise ParameterError(
                "camera sensor width must be the long side (images are landscape): "
                f"got {self.sensor_width_mm} x {self.sensor_height_mm} mm")

    @property
    def pixel_pitch_mm(self) -> float:
        """The width of one pixel on the sensor, millimetres."""
        return self.sensor_width_mm / self.image_width_px

    @property
    def tan_half_hfov(self) -> float:
        """The tangent of half the horizontal field of view."""
        return self.sensor_width_mm / (2.0 * self.focal_length_mm)

    @property
    def tan_half_vfov(self) -> float:
        """The tangent of half the vertical field of view."""
        return self.sensor_height_mm / (2.0 * self.focal_length_mm)

    @property
    def hfov_deg(self) -> float:
        """The horizontal field of view, degrees."""
        return math.degrees(2.0 * math.atan(self.tan_half_hfov))

    @property
    def vfov_deg(self) -> float:
        """The vertical field of view, degrees."""
        return math.degrees(2.0 * math.atan(self.tan_half_vfov))

    def gsd_at(self, distance_m):
        """Ground sampling distance (m/px) at a range in metres.

        Parameters
        ----------
        distance_m : float or array_like
            Ranges, metres.

        Returns
        -------
        float or ndarray
            Metres per pixel.
        """
        return np.asarray(distance_m, dtype=float) * self.pixel_pitch_mm / self.focal_length_mm

    def optimal_distance(self, gsd_m: float) -> float:
        """Largest range at which one pixel covers at most ``gsd_m`` metres.

        Parameters
        ----------
        gsd_m : float
            Metres per pixel.

        Returns
        -------
        float
            Metres.
        """
        check_positive("gsd", gsd_m)
        return float(gsd_m) * self.focal_length_mm / self.pixel_pitch_mm

    def footprint(self, distance_m: float) -> tuple[float, float]:
        """Width and height (m) imaged on a plane facing the camera at that distance.

        Parameters
        ----------
        distance_m : float
            Metres.

        Returns
        -------
        width, height : float
            Metres.
        """
        return 2.0 * distance_m * self.tan_half_hfov, 2.0 * distance_m * self.tan_half_vfov

    @property
    def corner_factor(self) -> float:
        """Range to an image corner on a facing plane, per metre of standoff."""
        return math.sqrt(1.0 + self.tan_half_hfov ** 2 + self.tan_half_vfov ** 2)

    def to_dict(self) -> dict:
        d = asdict(self)
        d.pop("name")
        if self.name:
            d["name"] = self.name
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "Camera":
        try:
            return cls(float(d["sensor_width_mm"]), float(d["sensor_height_mm"]),
                       float(d["focal_length_mm"]), d["image_width_px"], d["image_height_px"],
                       d.get("name"))
        except KeyError as exc:
            raise ParameterError(f"camera is missing {exc.args[0]!r}") from None
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"camera has a value that is not a number ({exc})") from None


def check_positive(name: str, value) -> float:
    """``value`` as a float, or a ParameterError naming ``name`` if it is not > 0.

    Parameters
    ----------
    name : str
        The quantity's name, for the message.
    value : object
        The value given.

    Returns
    -------
    float
        ``value``.

    Raises
    ------
    ParameterError
        When ``value`` is not a number greater than 0.
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a positive number, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ParameterError(f"{name} must be a positive number, got {value!r}")
    return v


_THESIS80_FOCAL = 18.0 / math.tan(math.radians(40.0))

PRESETS: dict[str, Camera] = {
    # DJI Phantom 4 Pro: 1" CMOS 13.2 x 8.8 mm, 8.8 mm lens (24 mm equiv.), 5472 x 3648 px
    # (DJI product specifications).
    "phantom4pro": Camera(13.2, 8.8, 8.8, 5472, 3648, "phantom4pro"),
    # DJI Mavic 3 Enterprise wide camera: 4/3 CMOS 17.3 x 13.0 mm, 24 mm equivalent
    # (12.29 mm on this sensor), 5280 x 3956 px (DJI Mavic 3E specifications).
    "mavic3e": Camera(17.3, 13.0, 12.29, 5280, 3956, "mavic3e"),
    # DJI Matrice 4E wide-angle camera: 4/3 CMOS 17.3 x 13.0 mm, 24 mm equiv. (12.29 mm),
    # 5280 x 3956 px, mechanical shutter (DJI Matrice 4E specifications).
    "matrice4e": Camera(17.3, 13.0, 12.29, 5280, 3956, "matrice4e"),
    # DJI Zenmuse P1 with the DL 35 mm lens: full frame 35.9 x 24.0 mm, 8192 x 5460 px
    # (DJI Zenmuse P1 specifications).
    "zenmuse-p1-35": Camera(35.9, 24.0, 35.0, 8192, 5460, "zenmuse-p1-35"),
    # Generic camera with the 80 degree horizontal field of view of the thesis experiments
    # (Chapter 4); 36 x 24 mm sensor and 6000 x 4000 px chosen as a common 3:2 format.
    "thesis80": Camera(36.0, 24.0, _THESIS80_FOCAL, 6000, 4000, "thesis80"),
}


def get_camera(name: str) -> Camera:
    """The camera preset called ``name``.

    Parameters
    ----------
    name : str
        A preset (``coverplan cameras`` lists them), in any case.

    Returns
    -------
    Camera

    Raises
    ------
    ParameterError
        For an unknown name; the message lists the presets that exist.

    Examples
    --------
    >>> import coverplan
    >>> camera = coverplan.get_camera("phantom4pro")
    >>> round(camera.optimal_distance(0.004), 2)  # metres from the surface for 4 mm/px
    14.59
    """
    try:
        return PRESETS[name.lower()]
    except KeyError:
        raise ParameterError(
            f"unknown camera preset {name!r}; presets: {', '.join(sorted(PRESETS))}") from None
