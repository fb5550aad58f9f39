"""Photos under field conditions: the drawn light and the camera's own effects.

The light is the drawn sun's, with cast shadows, passing clouds and auto exposure (metered
centre-weighted as DJI's cameras do, or averaged); the camera adds sensor noise, its tone curve
and motion blur. The surfaces wear the materials of ``materials.py``.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from coverplan.errors import ParameterError
from coverplan.geometry.orientation import camera_axes
from coverplan.sfm.materials import (
    FINEST_M,
    brick,
    facade_coordinates,
    physical_cells,
    physical_noise,
    pixel_footprint,
    tiles,
    windows,
)
from coverplan.sfm.render import _SUN, PhotoCamera, PhotoRenderer, check_texture

_SKY_FIELD = 0.92  # sky radiance relative to a sunlit white wall


_AMBIENT = 0.32  # skylight on a surface in shadow


# The camera: linear exposure metered to mid grey, sensor noise in linear light, then the tone
# curve every camera writes its JPEGs with (gamma 2.2, which lifts shadows), then 8 bits.
# Noise: a 1-inch sensor at base ISO has an SNR of about 40 dB at mid grey; a photo reduced 5x
# averages 25 pixels into one. Set so that mid grey carries ~1 DN after the tone curve and
# shadows ~1.3 DN: on the noisy side of what such a photo shows.
MID_GREY = 0.18


READ_NOISE = 1e-3  # linear, of full scale


SHOT_NOISE = 6e-5  # variance per unit of linear signal


GAMMA = 2.2


# DJI's cameras meter centre-weighted unless told otherwise (the Mobile SDK's CameraMeteringMode
# defaults to Center). Its weights are not published; assumed here: three quarters of the weight
# on a central disc 0.4 of the frame's height across, the rest fading over the frame.
METERING = ("center", "average")


_CENTRE_DISC = 0.4


_CENTRE_SHARE = 0.75


def check_metering(metering: str) -> str:
    """``metering`` if it names a metering mode, else a one-line ParameterError.

    Parameters
    ----------
    metering : str
        ``center`` or ``average``.

    Returns
    -------
    str
        ``metering``.

    Raises
    ------
    ParameterError
        For another name.
    """
    if metering not in METERING:
        raise ParameterError(f"unknown metering {metering!r}; choose one of {', '.join(METERING)}")
    return metering


def metering_weights(height: int, width: int, metering: str = "center") -> np.ndarray:
    """(height * width,) float weights, summing to 1, with which auto exposure averages a frame.

    Parameters
    ----------
    height, width : int
        Pixels.
    metering : {"center", "average"}
        The mode.

    Returns
    -------
    (height * width,) float
        Weights.
    """
    if check_metering(metering) == "average":
        return np.full(height * width, 1.0 / (height * width))
    y, x = np.mgrid[0:height, 0:width]
    r2 = ((x + 0.5 - width / 2.0) ** 2 + (y + 0.5 - height / 2.0) ** 2) / float(height) ** 2
    # A Gaussian with _CENTRE_SHARE of its mass within radius _CENTRE_DISC / 2.
    sigma2 = (_CENTRE_DISC / 2.0) ** 2 / (-2.0 * np.log(1.0 - _CENTRE_SHARE))
    w = np.exp(-0.5 * r2 / sigma2).ravel()
    return w / w.sum()


class FieldRenderer(PhotoRenderer):
    """Photos under field conditions: physical textures, the drawn light, camera effects.

    Parameters
    ----------
    scene : Scene
        The scene.
    photo : PhotoCamera
        The photo camera.
    ground_reach : float
        Metres.
    family : str
        The texture family.
    facades : bool
        Real façade materials.
    seed : int
        The textures' seed.
    metering : {"center", "average"}
        The auto exposure.
    """

    def __init__(self, scene, photo: PhotoCamera, ground_reach: float, family: str = "noise",
                 facades: bool = False, seed: int = 0, metering: str = "center"):
        self.family = check_texture(family)
        self.meter = metering_weights(photo.height, photo.width, metering)
        super().__init__(scene, photo, finest_texture_m=FINEST_M, ground_reach=ground_reach, seed=seed)
        self.facades = bool(facades)
        self.ground_z = float(scene.ground_z)
        self.ground_index = len(self.meshes) - 1
        rng = np.random.default_rng([seed, 17])
        # Per mesh: plaster (most often) or brick walls under harsh conditions.
        self.brick = rng.random(len(self.meshes)) < 0.35
        self.salt = int(rng.integers(1, 1 << 20))

    def _material(self, pts, normal, footprint, mesh_of_hit):
        if self.family == "cells":
            base = physical_cells(pts, footprint)
        else:
            base = physical_noise(pts, footprint, self.lattice)
        if not self.facades:
            return base, np.zeros(len(pts), dtype=bool)
        value = base.copy()
        glass = np.zeros(len(pts), dtype=bool)
        building = mesh_of_hit != self.ground_index
        wall = building & (np.abs(normal[:, 2]) < 0.5)
        roof = building & (normal[:, 2] >= 0.5)
        if wall.any():
            along, up = facade_coordinates(pts[wall], normal[wall], self.ground_z)
            plaster = 0.55 + 0.18 * (base[wall] - 0.5)  # a plain rendered wall: little contrast
            is_brick = self.brick[mesh_of_hit[wall]]
            wall_value = np.where(is_brick, brick(along, up, footprint[wall], self.salt), plaster)
            pane, frame = windows(along, up)
            wall_value = np.where(frame, 0.9, wall_value)
            value[wall] = wall_value
            glass[np.flatnonzero(wall)[pane]] = True
        if roof.any():
            value[roof] = tiles(pts[roof], normal[roof], footprint[roof]) * (0.9 + 0.2 * base[roof])
        return value, glass

    def render_with_points(self, position, heading_deg: float, pitch_deg: float, every: int = 7):
        """The materials in the ideal renderer's fixed light: no shadows, noise or blur.

        Parameters
        ----------
        position : (3,) float
            Camera centre.
        heading_deg, pitch_deg : float
            Orientation.
        every : int
            Pixel stride of the points returned.

        Returns
        -------
        image : (h, w) uint8
            The photo.
        seen : (k, 3) float
            Scene points.
        """
        return self.render_flown(position, heading_deg, pitch_deg, _SUN, 1.0, 1.0, np.zeros(3), 0.0, None,
                                 every=every)

    def render_flown(self, position, heading_deg, pitch_deg, sun, direct, exposure, velocity, shutter_s,
                     rng, every: int = 7):
        """One photo (h, w) uint8 from a drawn pose, in the drawn light, and the points seen.
        Without ``rng`` the light is plain: no cast shadows and no sensor noise.

        Parameters
        ----------
        position : (3,) float
            Camera centre.
        heading_deg, pitch_deg : float
            Orientation.
        sun : (3,) float
            Unit vector towards the sun.
        direct : float
            Direct sunlight.
        exposure : float
            Gain.
        velocity : (3,) float
            m/s during the exposure.
        shutter_s : float
            Exposure time.
        rng : numpy.random.Generator or None
            Shadows' and noise's draw; None renders plain light.
        every : int
            Pixel stride of the points returned.

        Returns
        -------
        image : (h, w) uint8
            The photo.
        seen : (k, 3) float
            Scene points.
        """
        dirs, hit, dist, mesh, pts, albedo, normal = self._cast(position, heading_deg, pitch_deg)
        img = np.full(len(dirs), _SKY_FIELD * (0.55 + 0.45 * direct), dtype=np.float64)
        seen = np.zeros((0, 3))
        if len(hit):
            d = dirs[hit]
            cos_inc = -np.einsum("ij,ij->i", normal, d)
            footprint = (pixel_footprint(dist, cos_inc, self.photo.fx) / self.scale[hit]).astype(np.float32)
            value, glass = self._material(pts, normal, footprint, mesh)
            lit = np.clip(normal @ sun, 0.0, None)
            facing = np.flatnonzero(lit > 0) if rng is not None else np.zeros(0, np.int64)
            if len(facing):  # cast shadows: is the sun hidden from the point?
                o = pts[facing] + normal[facing] * max(10 * self.rays.epsilon, 1e-3)
                _dist, blocker, _f = self.rays.first_hit(o, np.broadcast_to(sun, o.shape))
                lit[facing[blocker >= 0]] = 0.0
            radiance = value * albedo * (_AMBIENT + (1.0 - _AMBIENT) * direct * lit)
            if glass.any():  # a mirror of the sky: it moves with the camera, nothing to match
                r = d[glass] - 2.0 * np.einsum("ij,ij->i", d[glass], normal[glass])[:, None] * normal[glass]
                radiance[glass] = _SKY_FIELD * (0.35 + 0.5 * np.clip(r[:, 2], 0.0, 1.0)) * (0.6 + 0.4 * direct)
            img[hit] = radiance
            seen = pts[::every]
        img = img.reshape(self.photo.height, self.photo.width)
        # Auto exposure: the metered mean brought to mid grey, give or take the meter's whim.
        img *= exposure * MID_GREY / max(float(self.meter @ img.ravel()), 1e-6)
        img = _motion_blur(img, velocity, shutter_s, heading_deg, pitch_deg, dist if len(hit) else None,
                           self.photo.fx)
        if rng is not None:
            img = img + rng.normal(0.0, 1.0, img.shape) * np.sqrt(READ_NOISE ** 2 + SHOT_NOISE * np.clip(img, 0, None))
        out = np.clip(img, 0.0, 1.0) ** (1.0 / GAMMA)
        return np.round(out * 255.0).astype(np.uint8), seen


def _motion_blur(img, velocity, shutter_s, heading_deg, pitch_deg, distances, fx):
    """Smear the photo along the image motion of the drone's velocity during the exposure."""
    if distances is None or not len(distances):
        return img
    right, up, _forward = (np.asarray(a, dtype=float) for a in camera_axes(heading_deg, pitch_deg))
    shift = np.array([velocity @ right, -(velocity @ up)]) * shutter_s * fx / float(np.median(distances))
    length = float(np.hypot(*shift))
    if length < 0.5:  # under half a pixel: nothing a photo would show
        return img
    n = int(np.ceil(length)) * 2 + 1
    kernel = np.zeros((n, n))
    c = n // 2
    for t in np.linspace(-0.5, 0.5, 4 * n):  # a line of the blur's length and direction
        kernel[int(round(c + t * shift[1])), int(round(c + t * shift[0]))] += 1.0
    return ndimage.convolve(img, kernel / kernel.sum(), mode="nearest")
