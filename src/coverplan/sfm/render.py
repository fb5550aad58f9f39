"""Photos a route would take, ray cast on the scene with a procedural texture.

The texture is 3D value noise summed over octaves (solid, so it never repeats along a wall
and needs no UV map), times a per-face albedo and a sun/sky shading, on every mesh and on a
ground plane. Its finest octave is kept a few pixels wide at the flight's range so that the
reduced-resolution photos are not aliased.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from ..orientation import camera_axes
from ..raycast import RayCaster

_SUN = np.array([0.35, -0.45, 0.82]) / np.linalg.norm([0.35, -0.45, 0.82])
_SKY = 0.78  # sky brightness (no texture: nothing to match there)
_OCTAVES = 5


@dataclass(frozen=True)
class PhotoCamera:
    """A pinhole camera with the route camera's field of view at a reduced resolution."""

    width: int
    height: int
    fx: float
    fy: float

    @property
    def cx(self) -> float:
        return self.width / 2.0

    @property
    def cy(self) -> float:
        return self.height / 2.0

    @classmethod
    def of(cls, camera, width: int) -> "PhotoCamera":
        width = int(width)
        height = max(8, int(round(width * camera.image_height_px / camera.image_width_px)))
        return cls(width, height, width / (2.0 * camera.tan_half_hfov), height / (2.0 * camera.tan_half_vfov))

    def rays(self, heading_deg: float, pitch_deg: float) -> np.ndarray:
        """World directions (h*w, 3) through every pixel centre, row-major from the top left."""
        right, up, forward = (np.asarray(a, dtype=float) for a in camera_axes(heading_deg, pitch_deg))
        u = (np.arange(self.width) + 0.5 - self.cx) / self.fx
        v = (np.arange(self.height) + 0.5 - self.cy) / self.fy
        uu, vv = np.meshgrid(u, v)
        d = forward + uu.reshape(-1, 1) * right - vv.reshape(-1, 1) * up
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    def gsd_at(self, distance: float) -> float:
        return float(distance) / self.fx


def ground_plane(scene, reach: float) -> trimesh.Trimesh:
    """A square at the scene's ground height reaching ``reach`` beyond every mesh; over
    terrain, the terrain's own surface."""
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
    """The random values the corner hash indexes (4 MB)."""
    return np.random.default_rng(seed).random(1 << _TABLE_BITS, dtype=np.float32)


def value_noise(points: np.ndarray, cell: float, lattice: np.ndarray, shift: int) -> np.ndarray:
    """Smooth 3D value noise in [0, 1] with lattice cells of ``cell`` metres.

    Corner values come from a spatial hash of the integer corner, not from a wrapped lattice:
    a repeating texture lets SfM match one wall to another (seen: whole storeys misplaced)."""
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
    """Multi-scale solid texture in [0, 1]: octaves from ``finest`` metres up, doubling."""
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
    """Renders grey photos of a scene (its meshes plus a ground plane) from route poses."""

    def __init__(self, scene, photo: PhotoCamera, finest_texture_m: float, ground_reach: float, seed: int = 0):
        self.photo = photo
        self.finest = float(finest_texture_m)
        self.lattice = noise_lattice(seed)
        self.meshes = list(scene.meshes) + [ground_plane(scene, ground_reach)]
        self.rays = RayCaster(self.meshes, epsilon=scene.epsilon)
        rng = np.random.default_rng(seed)
        # One albedo per face: neighbouring faces and parts differ in tone, as materials do.
        self.albedo = [0.7 + 0.3 * rng.random(len(m.faces)) for m in self.meshes]
        self.normals = [np.asarray(m.face_normals, dtype=float) for m in self.meshes]

    def render(self, position, heading_deg: float, pitch_deg: float) -> np.ndarray:
        """One photo as a (height, width) uint8 array."""
        return self.render_with_points(position, heading_deg, pitch_deg)[0]

    def render_with_points(self, position, heading_deg: float, pitch_deg: float, every: int = 7):
        """One photo and the scene points seen by every ``every``-th pixel (for pairing)."""
        dirs = self.photo.rays(heading_deg, pitch_deg)
        origin = np.broadcast_to(np.asarray(position, dtype=float), dirs.shape)
        dist, mesh, face = self.rays.first_hit(origin, dirs)
        img = np.full(len(dirs), _SKY)
        hit = np.flatnonzero(mesh >= 0)
        seen = np.zeros((0, 3))
        if len(hit):
            pts = origin[hit] + dirs[hit] * dist[hit, None]
            albedo = np.empty(len(hit))
            normal = np.empty((len(hit), 3))
            for m in np.unique(mesh[hit]):
                sel = mesh[hit] == m
                albedo[sel] = self.albedo[m][face[hit][sel]]
                normal[sel] = self.normals[m][face[hit][sel]]
            # Shade by the side facing the camera, so open meshes look the same from both sides.
            normal *= -np.sign(np.einsum("ij,ij->i", normal, dirs[hit]))[:, None]
            shade = 0.6 + 0.4 * np.clip(normal @ _SUN, 0.0, 1.0)
            img[hit] = (0.08 + 0.92 * texture(pts, self.finest, self.lattice)) * albedo * shade
            seen = pts[::every]
        return np.clip(img * 255.0, 0, 255).astype(np.uint8).reshape(self.photo.height, self.photo.width), seen
