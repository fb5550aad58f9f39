"""Photos a route would take, ray cast on the scene with a procedural texture.

The ideal texture is 3D value noise summed over octaves (solid, so it never repeats along a
wall and needs no UV map), times a per-face albedo and a sun/sky shading, on every mesh and on
a ground plane. Its finest octave is kept a few pixels wide at the flight's range so that the
reduced-resolution photos are not aliased.

Under field conditions (``conditions.py``) the materials are ``materials.py``'s and the light,
shadows and camera effects ``field_render.py``'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

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
