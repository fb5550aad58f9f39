"""Photos a route would take, ray cast on the scene with a procedural texture.

The ideal texture is 3D value noise summed over octaves (solid, so it never repeats along a
wall and needs no UV map), times a per-face albedo and a sun/sky shading, on every mesh and on
a ground plane. Its finest octave is kept a few pixels wide at the flight's range so that the
reduced-resolution photos are not aliased.

Under field conditions (``conditions.py``) the textures are the materials' own: octaves from
millimetres to metres, each faded out where a pixel's footprint on the surface is too wide to
show it (so a far or grazing photo sees a plainer wall, as a real one does), in one of two
families with different statistics: ``noise`` (smooth value noise) and ``cells`` (cellular
stone: flat tones with sharp joints). The light is the drawn sun's, with cast shadows, passing
clouds, auto exposure, sensor noise and motion blur. ``harsh`` adds real façades: low-contrast
plaster or brick courses, a regular grid of identical windows whose glass mirrors the sky,
and roofs of repeated tiles.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from scipy import ndimage

from coverplan.equipment.lens import PINHOLE, Lens
from coverplan.errors import ParameterError
from coverplan.geometry.orientation import camera_axes
from coverplan.geometry.raycast import RayCaster

_SUN = np.array([0.35, -0.45, 0.82]) / np.linalg.norm([0.35, -0.45, 0.82])
_SKY = 0.78  # sky brightness (no texture: nothing to match there)
_OCTAVES = 5


@dataclass(frozen=True)
class PhotoCamera:
    """The route camera's field of view at a reduced resolution: a pinhole, or through ``lens``
    (photos as a real lens draws them).

    Parameters
    ----------
    width, height : int
        Pixels.
    fx, fy : float
        Focal lengths, px.
    lens : Lens
        The distortion drawn through.
    """

    width: int
    height: int
    fx: float
    fy: float
    lens: Lens = PINHOLE

    @property
    def cx(self) -> float:
        """The principal point's x, px: the photo's centre."""
        return self.width / 2.0

    @property
    def cy(self) -> float:
        """The principal point's y, px: the photo's centre."""
        return self.height / 2.0

    @classmethod
    def of(cls, camera, width: int, lens: Lens = PINHOLE) -> "PhotoCamera":
        """The route camera's field of view at ``width`` pixels across.

        Parameters
        ----------
        camera : Camera
            The route's camera.
        width : int
            Pixels.
        lens : Lens
            The distortion drawn through.

        Returns
        -------
        PhotoCamera
            The photo camera.
        """
        width = int(width)
        height = max(8, int(round(width * camera.image_height_px / camera.image_width_px)))
        return cls(width, height, width / (2.0 * camera.tan_half_hfov), height / (2.0 * camera.tan_half_vfov), lens)

    def rays(self, heading_deg: float, pitch_deg: float) -> np.ndarray:
        """World directions (h*w, 3) through every pixel centre, row-major from the top left.

        Parameters
        ----------
        heading_deg, pitch_deg : float
            The camera's orientation.

        Returns
        -------
        (h*w, 3) float
            Unit vectors.
        """
        right, up, forward = (np.asarray(a, dtype=float) for a in camera_axes(heading_deg, pitch_deg))
        u = (np.arange(self.width) + 0.5 - self.cx) / self.fx
        v = (np.arange(self.height) + 0.5 - self.cy) / self.fy
        uu, vv = np.meshgrid(u, v)
        if not self.lens.is_pinhole:  # each pixel sees along the ray the lens bends onto it
            uu, vv = self.lens.undistort(np.column_stack([uu.ravel(), vv.ravel()])).T
        d = forward + uu.reshape(-1, 1) * right - vv.reshape(-1, 1) * up
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    def gsd_at(self, distance: float) -> float:
        """Metres per pixel at the photo's centre at ``distance`` metres.

        Parameters
        ----------
        distance : float
            Metres.

        Returns
        -------
        float
            Metres per pixel.
        """
        return float(distance) / self.fx

    def pixel_scale(self) -> np.ndarray:
        """(h*w,) how much each pixel is magnified against the pinhole at the photo's centre,
        the smaller of the lens's radial and tangential scale there (1 for a pinhole; a barrel
        lens squeezes more of the scene into each pixel towards the corners).

        Returns
        -------
        (h*w,) float
            Magnification per pixel.
        """
        if self.lens.is_pinhole:
            return np.ones(self.width * self.height)
        u = (np.arange(self.width) + 0.5 - self.cx) / self.fx
        v = (np.arange(self.height) + 0.5 - self.cy) / self.fy
        r_d = np.hypot(*np.meshgrid(u, v)).ravel()
        grid = np.linspace(0.0, float(r_d.max()) * 1.001 + 1e-3, 256)
        r_u = self.lens.undistort(np.column_stack([grid, np.zeros_like(grid)]))[:, 0]
        radial = np.gradient(grid, r_u)
        tangential = np.where(r_u > 0, grid / np.maximum(r_u, 1e-12), 1.0)
        return np.clip(np.interp(r_d, grid, np.minimum(radial, tangential)), 0.05, None)


def ground_plane(scene, reach: float) -> trimesh.Trimesh:
    """A square at the scene's ground height reaching ``reach`` beyond every mesh; over
    terrain, the terrain's own surface.

    Parameters
    ----------
    scene : Scene
        The scene.
    reach : float
        Metres.

    Returns
    -------
    trimesh.Trimesh
        The ground.
    """
    if scene.terrain is not None:
        return scene.terrain.mesh
    lo, hi = scene.bounds()
    x0, y0 = lo[:2] - reach
    x1, y1 = hi[:2] + reach
    z = float(scene.ground_z) - 1e-3
    v = np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]])
    return trimesh.Trimesh(v, np.array([[0, 1, 2], [0, 2, 3]]), process=False)


_TABLE_BITS = 20  # random values looked up by a hash of the lattice corner (never periodic)
_PRIMES = (np.uint32(73856093), np.uint32(19349663), np.uint32(83492791))


def noise_lattice(seed: int) -> np.ndarray:
    """The random values the corner hash indexes (4 MB).

    Parameters
    ----------
    seed : int
        The values' seed.

    Returns
    -------
    (2**20,) float32
        Values in [0, 1).
    """
    return np.random.default_rng(seed).random(1 << _TABLE_BITS, dtype=np.float32)


def value_noise(points: np.ndarray, cell: float, lattice: np.ndarray, shift: int) -> np.ndarray:
    """Smooth 3D value noise in [0, 1] with lattice cells of ``cell`` metres.

    Corner values come from a spatial hash of the integer corner, not from a wrapped lattice:
    a repeating texture lets SfM match one wall to another (seen: whole storeys misplaced).

    Parameters
    ----------
    points : (n, 3) float
        Surface points.
    cell : float
        Metres.
    lattice : (m,) float32
        ``noise_lattice``'s values.
    shift : int
        Salt of the hash, one per octave.

    Returns
    -------
    (n,) float
        Noise.
    """
    p = (points / cell).astype(np.float64)
    base = np.floor(p)
    f = (p - base).astype(np.float32)
    f = f * f * (3.0 - 2.0 * f)
    i = (base.astype(np.int64) + shift).astype(np.uint32)  # wraps only after 2^32 cells
    axis = [[(i[:, a] + np.uint32(d)) * _PRIMES[a] for d in (0, 1)] for a in range(3)]
    w = [(1.0 - f[:, a], f[:, a]) for a in range(3)]
    mask = np.uint32((1 << _TABLE_BITS) - 1)
    out = np.zeros(len(points), dtype=np.float32)
    for dx in (0, 1):
        for dy in (0, 1):
            hxy = axis[0][dx] ^ axis[1][dy]
            wxy = w[0][dx] * w[1][dy]
            for dz in (0, 1):
                h = (hxy ^ axis[2][dz]) * np.uint32(0x5BD1E995)
                h ^= h >> np.uint32(15)
                out += wxy * w[2][dz] * lattice[h & mask]
    return out


def texture(points: np.ndarray, finest: float, lattice: np.ndarray) -> np.ndarray:
    """Multi-scale solid texture in [0, 1]: octaves from ``finest`` metres up, doubling.

    Parameters
    ----------
    points : (n, 3) float
        Surface points.
    finest : float
        Metres.
    lattice : (m,) float32
        ``noise_lattice``'s values.

    Returns
    -------
    (n,) float
        Albedo factor.
    """
    total = np.zeros(len(points), dtype=np.float32)
    weight = 0.0
    for k in range(_OCTAVES):
        amp = 0.8 ** k
        # Octaves shifted by unrelated offsets so their lattices never line up.
        total += amp * value_noise(points, finest * 2.0 ** k, lattice, 37 * k + 11)
        weight += amp
    t = total / weight
    # Stretch the noise's narrow middle-heavy histogram to use the whole grey range.
    return np.clip((t - 0.5) * 3.2 + 0.5, 0.0, 1.0)


class PhotoRenderer:
    """Renders grey photos of a scene (its meshes plus a ground plane) from route poses.

    Parameters
    ----------
    scene : Scene
        The scene.
    photo : PhotoCamera
        The photo camera.
    finest_texture_m : float
        The finest texture octave, metres.
    ground_reach : float
        How far the ground plane reaches beyond the meshes, metres.
    seed : int
        The textures' and tones' seed.
    """

    def __init__(self, scene, photo: PhotoCamera, finest_texture_m: float, ground_reach: float, seed: int = 0):
        self.photo = photo
        self.scale = photo.pixel_scale()
        self.finest = float(finest_texture_m)
        self.lattice = noise_lattice(seed)
        self.meshes = list(scene.meshes) + [ground_plane(scene, ground_reach)]
        self.rays = RayCaster(self.meshes, epsilon=scene.epsilon)
        rng = np.random.default_rng(seed)
        # One albedo per face: neighbouring faces and parts differ in tone, as materials do.
        self.albedo = [0.7 + 0.3 * rng.random(len(m.faces)) for m in self.meshes]
        self.normals = [np.asarray(m.face_normals, dtype=float) for m in self.meshes]

    def _cast(self, position, heading_deg: float, pitch_deg: float):
        """Every pixel's ray, which hit something, and at the hits: distance, mesh, point, albedo
        and the normal of the side facing the camera (open meshes look the same from both sides)."""
        dirs = self.photo.rays(heading_deg, pitch_deg)
        origin = np.broadcast_to(np.asarray(position, dtype=float), dirs.shape)
        dist, mesh, face = self.rays.first_hit(origin, dirs)
        hit = np.flatnonzero(mesh >= 0)
        pts = origin[hit] + dirs[hit] * dist[hit, None]
        albedo = np.empty(len(hit))
        normal = np.empty((len(hit), 3))
        for m in np.unique(mesh[hit]):
            sel = mesh[hit] == m
            albedo[sel] = self.albedo[m][face[hit][sel]]
            normal[sel] = self.normals[m][face[hit][sel]]
        normal *= -np.sign(np.einsum("ij,ij->i", normal, dirs[hit]))[:, None]
        return dirs, hit, dist[hit], mesh[hit], pts, albedo, normal

    def render(self, position, heading_deg: float, pitch_deg: float) -> np.ndarray:
        """One photo as a (height, width) uint8 array.

        Parameters
        ----------
        position : (3,) float
            Camera centre.
        heading_deg, pitch_deg : float
            Orientation.

        Returns
        -------
        (h, w) uint8
            The photo.
        """
        return self.render_with_points(position, heading_deg, pitch_deg)[0]

    def render_with_points(self, position, heading_deg: float, pitch_deg: float, every: int = 7):
        """One photo and the scene points seen by every ``every``-th pixel (for pairing).

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
        dirs, hit, dist, mesh, pts, albedo, normal = self._cast(position, heading_deg, pitch_deg)
        img = np.full(len(dirs), _SKY)
        seen = np.zeros((0, 3))
        if len(hit):
            shade = 0.6 + 0.4 * np.clip(normal @ _SUN, 0.0, 1.0)
            img[hit] = (0.08 + 0.92 * texture(pts, self.finest, self.lattice)) * albedo * shade
            seen = pts[::every]
        return np.clip(img * 255.0, 0, 255).astype(np.uint8).reshape(self.photo.height, self.photo.width), seen


# -- field conditions: physical textures, light, camera -----------------------------------------

TEXTURE_FAMILIES = ("noise", "cells")


def ground_reach(d_opt: float, security: float) -> float:
    """How far the rendered ground reaches beyond the meshes: farther than any photo looks.

    Parameters
    ----------
    d_opt : float
        Metres.
    security : float
        Metres.

    Returns
    -------
    float
        Metres.
    """
    return 4.0 * float(d_opt) + float(security)


def ideal_renderer(scene, photo: PhotoCamera, d_opt: float, security: float, seed: int = 0) -> PhotoRenderer:
    """The renderer of ``--conditions ideal``: value noise whose finest octave is about 2.5 px
    wide at 80 % of d_opt (the usual standoff), visible and not aliased.

    Parameters
    ----------
    scene : Scene
        The scene.
    photo : PhotoCamera
        The photo camera.
    d_opt, security : float
        Metres.
    seed : int
        The textures' seed.

    Returns
    -------
    PhotoRenderer
        The renderer.
    """
    return PhotoRenderer(scene, photo, finest_texture_m=2.5 * photo.gsd_at(0.8 * d_opt),
                         ground_reach=ground_reach(d_opt, security), seed=seed)


def check_texture(family: str) -> str:
    """``family`` if it names a texture family, else a one-line ParameterError.

    Parameters
    ----------
    family : str
        A texture family's name.

    Returns
    -------
    str
        ``family``.

    Raises
    ------
    ParameterError
        For another name.
    """
    if family not in TEXTURE_FAMILIES:
        raise ParameterError(f"unknown texture family {family!r}; choose one of {', '.join(TEXTURE_FAMILIES)}")
    return family

FINEST_M = 0.004  # plaster grain, sand, stone pores
COARSEST_M = 4.0  # stains, weathering, patches
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


def pixel_footprint(distance: np.ndarray, cos_incidence: np.ndarray, fx: float) -> np.ndarray:
    """(n,) metres of surface one pixel spans along its longer side.

    Parameters
    ----------
    distance : (n,) float
        Metres.
    cos_incidence : (n,) float
        Cosine of the incidence.
    fx : float
        Focal length, px.

    Returns
    -------
    (n,) float
        Metres.
    """
    return distance / fx / np.maximum(np.abs(cos_incidence), 0.2)


def _fade(scale_m, footprint) -> np.ndarray:
    """Contrast kept of a pattern of ``scale_m`` seen through pixels of ``footprint`` metres:
    all of it from 2 px per period, none under 1 px (it averages out instead of aliasing)."""
    return np.clip(np.asarray(scale_m, dtype=np.float32) / footprint - 1.0, 0.0, 1.0).astype(np.float32)


def physical_noise(points: np.ndarray, footprint: np.ndarray, lattice: np.ndarray) -> np.ndarray:
    """Value noise with equal energy per octave from FINEST_M to COARSEST_M, filtered by footprint.

    Parameters
    ----------
    points : (n, 3) float
        Surface points.
    footprint : (n,) float
        Metres per pixel there.
    lattice : (m,) float32
        ``noise_lattice``'s values.

    Returns
    -------
    (n,) float
        Albedo.
    """
    n_oct = int(round(np.log2(COARSEST_M / FINEST_M))) + 1
    total = np.zeros(len(points), dtype=np.float32)
    for k in range(n_oct):
        cell = FINEST_M * 2.0 ** k
        w = _fade(cell, footprint)
        live = np.flatnonzero(w > 0)
        if len(live):
            total[live] += w[live] * (value_noise(points[live], cell, lattice, 53 * k + 5) - 0.5)
    # Seven visible octaves (a photo at a usual standoff) have about the ideal texture's contrast.
    return np.clip(0.5 + total * 0.55, 0.0, 1.0)


def _cell_hash(i: np.ndarray, salt: int) -> np.ndarray:
    """A uint32 hash per integer 3D cell (n, 3)."""
    u = i.astype(np.uint32)
    h = (u[:, 0] * _PRIMES[0]) ^ (u[:, 1] * _PRIMES[1]) ^ (u[:, 2] * _PRIMES[2]) ^ np.uint32(salt * 0x9E3779B1 & 0xFFFFFFFF)
    h = h * np.uint32(0x5BD1E995)
    return h ^ (h >> np.uint32(15))


def cellular(points: np.ndarray, size: float, salt: int):
    """Worley cells of about ``size`` metres: (tone in [0, 1] of the nearest cell, metres to the
    joint with the next cell, doubled). Feature points are searched in the 2 x 2 x 2 cells
    nearest the point, which finds the nearest one nearly always at an eighth of the work.

    Parameters
    ----------
    points : (n, 3) float
        Surface points.
    size : float
        Metres.
    salt : int
        The hash's salt.

    Returns
    -------
    tone : (n,) float
        The nearest cell's tone.
    gap : (n,) float
        Metres to the joint, doubled.
    """
    p = (points / size).astype(np.float32)
    base = np.floor(p)
    near = np.where(p - base < 0.5, -1, 0).astype(np.int64) + base.astype(np.int64)
    best = np.full(len(p), np.inf, dtype=np.float32)
    second = np.full(len(p), np.inf, dtype=np.float32)
    tone = np.zeros(len(p), dtype=np.float32)
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                c = near + np.array([dx, dy, dz])
                h = _cell_hash(c, salt)
                d = np.zeros(len(p), dtype=np.float32)
                for a, shift in enumerate((0, 10, 20)):
                    e = c[:, a] + ((h >> np.uint32(shift)) & np.uint32(0x3FF)).astype(np.float32) / 1024.0 - p[:, a]
                    d += e * e
                closer = d < best
                np.copyto(second, np.where(closer, best, np.minimum(second, d)))
                np.copyto(tone, ((h >> np.uint32(7)) & np.uint32(0xFF)).astype(np.float32) / 255.0, where=closer)
                np.copyto(best, d, where=closer)
    gap = (np.sqrt(second) - np.sqrt(best)) * size
    return tone, gap


def physical_cells(points: np.ndarray, footprint: np.ndarray) -> np.ndarray:
    """Cellular stone: blocks of two sizes with their own tones and dark joints, filtered.

    Parameters
    ----------
    points : (n, 3) float
        Surface points.
    footprint : (n,) float
        Metres per pixel there.

    Returns
    -------
    (n,) float
        Albedo.
    """
    out = np.full(len(points), 0.5, dtype=np.float32)
    for size, amp, salt in ((0.45, 0.5, 3), (0.09, 0.35, 5), (0.02, 0.25, 7)):
        w = _fade(size, footprint)
        live = np.flatnonzero(w > 0)
        if not len(live):
            continue
        tone, gap = cellular(points[live], size, salt)
        joint = np.clip(1.0 - gap / (0.08 * size), 0.0, 1.0)  # joints about 4 % of a block
        wj = _fade(0.08 * size, footprint[live])
        out[live] += w[live] * amp * (tone - 0.5) - wj * 0.45 * amp * joint
    return np.clip(out, 0.0, 1.0)


def _filtered_pulse(x: np.ndarray, period: float, width: float, footprint: np.ndarray) -> np.ndarray:
    """Share of a box of ``footprint`` around x covered by lines ``width`` wide every ``period``."""
    def integral(y):
        return np.floor(y / period) * width + np.minimum(np.mod(y, period), width)
    f = np.maximum(footprint, 1e-6)
    return (integral(x + 0.5 * f) - integral(x - 0.5 * f)) / f


def facade_coordinates(points: np.ndarray, normals: np.ndarray, ground_z: float):
    """(along, up): metres along a wall (horizontal, perpendicular to its normal) and above ground.

    Parameters
    ----------
    points, normals : (n, 3) float
        Wall points.
    ground_z : float
        Metres.

    Returns
    -------
    along, up : (n,) float
        Metres.
    """
    t = np.column_stack([-normals[:, 1], normals[:, 0]])
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-9)
    return np.einsum("ij,ij->i", points[:, :2], t), points[:, 2] - ground_z


def brick(along, up, footprint, salt: int) -> np.ndarray:
    """Courses of 7.1 cm (6.1 cm bricks, 1 cm joints), bricks 24 cm long in stretcher bond,
    one tone per brick.

    Parameters
    ----------
    along, up : (n,) float
        ``facade_coordinates``.
    footprint : (n,) float
        Metres per pixel there.
    salt : int
        The tones' salt.

    Returns
    -------
    (n,) float
        Albedo.
    """
    course, length, joint = 0.071, 0.24, 0.01
    row = np.floor(up / course)
    shifted = along + 0.5 * length * (row % 2)
    ids = np.column_stack([np.floor(shifted / length), row, np.zeros_like(row)]).astype(np.int64)
    tone = ((_cell_hash(ids, salt) >> 9) & 0xFF) / 255.0
    mortar = np.maximum(_filtered_pulse(up, course, joint, footprint),
                        _filtered_pulse(shifted, length, joint, footprint))
    value = 0.5 + 0.3 * _fade(course, footprint) * (tone - 0.5)
    return value * (1.0 - mortar) + 0.82 * mortar


WINDOW_BAY_M, STOREY_M = 2.6, 3.0
WINDOW_W, WINDOW_H, SILL_M, FRAME_M = 1.2, 1.4, 0.9, 0.07


def windows(along, up):
    """(glass, frame) masks of a regular grid of identical windows, storey by storey.

    Parameters
    ----------
    along, up : (n,) float
        ``facade_coordinates``.

    Returns
    -------
    glass, frame : (n,) bool
        Masks.
    """
    a = np.mod(along, WINDOW_BAY_M) - 0.5 * (WINDOW_BAY_M - WINDOW_W)
    b = np.mod(up, STOREY_M) - SILL_M
    inside = (a >= 0) & (a <= WINDOW_W) & (b >= 0) & (b <= WINDOW_H) & (up > SILL_M)
    border = np.minimum(np.minimum(a, WINDOW_W - a), np.minimum(b, WINDOW_H - b))
    frame = inside & (border < FRAME_M)
    return inside & ~frame, frame


def tiles(points, normals, footprint) -> np.ndarray:
    """Roof tiles in rows 33 cm apart down the slope, 22 cm wide, each shaded alike.

    Parameters
    ----------
    points, normals : (n, 3) float
        Roof points.
    footprint : (n,) float
        Metres per pixel there.

    Returns
    -------
    (n,) float
        Albedo.
    """
    h = normals[:, :2]
    hn = np.linalg.norm(h, axis=1, keepdims=True)
    down = np.where(hn > 0.05, h / np.maximum(hn, 1e-9), [[0.0, 1.0]])
    across = np.column_stack([-down[:, 1], down[:, 0]])
    s = np.einsum("ij,ij->i", points[:, :2], down)
    u = np.einsum("ij,ij->i", points[:, :2], across)
    pitch, width = 0.33, 0.22
    row = np.floor(s / pitch)
    f = np.mod(s, pitch) / pitch
    shown = _fade(pitch, footprint)
    gradient = 0.35 + 0.45 * f * shown  # each tile darkens under the one above
    seam = _filtered_pulse(u + 0.5 * width * (row % 2), width, 0.012, footprint)
    return np.where(shown > 0, gradient * (1.0 - 0.6 * seam), 0.55)


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
