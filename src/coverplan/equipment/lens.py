"""A camera's lens distortion: the Brown-Conrady model that OpenCV, COLMAP and DJI's
``DewarpData`` share.

A point at normalised image coordinates ``(x, y)`` (pinhole: ``X/Z, Y/Z``) is imaged at

    r² = x² + y²,  radial = 1 + k1 r² + k2 r⁴ + k3 r⁶
    x_d = x radial + 2 p1 x y + p2 (r² + 2 x²)
    y_d = y radial + p1 (r² + 2 y²) + 2 p2 x y

The coefficients do not depend on the image's resolution, so a lens calibrated on the full
sensor distorts a reduced-size photo of it the same way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from coverplan.errors import ParameterError

UNDISTORT_ITERATIONS = 20


@dataclass(frozen=True)
class Lens:
    """Radial (``k1``, ``k2``, ``k3``) and tangential (``p1``, ``p2``) distortion; all zero is a
    pinhole.

    Parameters
    ----------
    k1, k2, k3 : float
        Radial coefficients (Brown-Conrady, normalised image coordinates).
    p1, p2 : float
        Tangential coefficients.
    source : str
        Where the coefficients come from.
    """

    k1: float = 0.0
    k2: float = 0.0
    p1: float = 0.0
    p2: float = 0.0
    k3: float = 0.0
    source: str = ""

    def __post_init__(self):
        for name in ("k1", "k2", "p1", "p2", "k3"):
            v = float(getattr(self, name))
            if not np.isfinite(v) or abs(v) > 10.0:
                raise ParameterError(f"lens distortion {name} must be a finite number within +-10, got {v!r}")

    @property
    def is_pinhole(self) -> bool:
        """True when every coefficient is zero."""
        return not any((self.k1, self.k2, self.p1, self.p2, self.k3))

    @property
    def opencv(self) -> tuple[float, float, float, float, float]:
        """(k1, k2, p1, p2, k3), in OpenCV's order."""
        return (float(self.k1), float(self.k2), float(self.p1), float(self.p2), float(self.k3))

    def distort(self, xy: np.ndarray) -> np.ndarray:
        """Where the lens images normalised points.

        Parameters
        ----------
        xy : (n, 2) float
            Undistorted normalised image coordinates.

        Returns
        -------
        (n, 2) float
            Distorted normalised image coordinates.
        """
        xy = np.asarray(xy, dtype=float)
        x, y = xy[:, 0], xy[:, 1]
        r2 = x * x + y * y
        radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3))
        xd = x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x)
        yd = y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y
        return np.column_stack([xd, yd])

    def undistort(self, xy_d: np.ndarray) -> np.ndarray:
        """The normalised points the lens images at ``xy_d`` (n, 2): the inverse of ``distort``,
        by fixed-point iteration (converges for the distortion of a photo lens within its
        field of view).

        Parameters
        ----------
        xy_d : (n, 2) float
            Distorted normalised image coordinates.

        Returns
        -------
        (n, 2) float
            Undistorted normalised coordinates.
        """
        xy_d = np.asarray(xy_d, dtype=float)
        if self.is_pinhole:
            return xy_d.copy()
        xy = xy_d.copy()
        for _ in range(UNDISTORT_ITERATIONS):
            x, y = xy[:, 0], xy[:, 1]
            r2 = x * x + y * y
            radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3))
            dx = 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x)
            dy = self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y
            xy = np.column_stack([(xy_d[:, 0] - dx) / radial, (xy_d[:, 1] - dy) / radial])
        return xy

    def dewarp_data(self, fx: float, fy: float, dx: float = 0.0, dy: float = 0.0, date: str = "2024-01-01") -> str:
        """The lens as DJI's ``DewarpData`` XMP tag: ``date;fx,fy,cx,cy,k1,k2,p1,p2,k3`` (focal
        lengths in px, the optical centre's offset from the photo's centre in px).

        Parameters
        ----------
        fx, fy : float
            Focal lengths, px.
        dx, dy : float
            The optical centre's offset from the photo's centre, px.
        date : str
            The calibration date written first.

        Returns
        -------
        str
            The tag's value.
        """
        values = (fx, fy, dx, dy) + self.opencv
        return f"{date};" + ",".join(f"{float(v):.12f}" for v in values)


PINHOLE = Lens()


@dataclass(frozen=True)
class Dewarp:
    """DJI's ``DewarpData``: the calibrated focal lengths (px), optical-centre offset from the
    photo's centre (px) and the lens.

    Parameters
    ----------
    fx, fy : float
        Focal lengths, px.
    dx, dy : float
        Optical-centre offset from the photo's centre, px.
    lens : Lens
        The distortion.
    """

    fx: float
    fy: float
    dx: float
    dy: float
    lens: Lens


def parse_dewarp_data(text: str) -> Dewarp | None:
    """DJI's ``DewarpData`` (``date;fx,fy,cx,cy,k1,k2,p1,p2,k3``), or None if ``text`` is not one.

    Parameters
    ----------
    text : str
        The tag's value.

    Returns
    -------
    Dewarp or None
        The calibration.
    """
    if not text:
        return None
    body = str(text).strip().rpartition(";")[2]
    try:
        values = [float(v) for v in body.split(",")]
    except ValueError:
        return None
    if len(values) < 9 or not all(np.isfinite(values[:9])) or values[0] <= 0 or values[1] <= 0:
        return None
    fx, fy, dx, dy, k1, k2, p1, p2, k3 = values[:9]
    try:
        lens = Lens(k1, k2, p1, p2, k3, source="DJI DewarpData")
    except ParameterError:
        return None
    return Dewarp(fx, fy, dx, dy, lens)
