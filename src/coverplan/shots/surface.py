"""Surface samples of the target: even by area, with outward normals, area weights and a
class per sample (facade / roof / terrace / opposed terrace, as in the thesis's Figure 3.1).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from coverplan.equipment.camera import check_positive
from coverplan.errors import ParameterError, PlanningError

FACADE, ROOF, TERRACE, OPPOSED_TERRACE = 0, 1, 2, 3
CLASS_NAMES = ("facade", "roof", "terrace", "opposed_terrace")
# |normal_z| below this is a wall; above it (up or down) a roof-like surface.
FACADE_MAX_NZ = 0.5
_BUCKETS = np.array([(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)
                     if (i, j, k) != (0, 0, 0)], dtype=float)
_BUCKETS /= np.linalg.norm(_BUCKETS, axis=1, keepdims=True)
_MAX_DENSE = 4_000_000


@dataclass
class SurfaceSamples:
    """Points on the target surface; each stands for ``area`` m^2 around it.

    Parameters
    ----------
    points : (n, 3) float
        Sample positions.
    normals : (n, 3) float
        Unit outward normals.
    area : (n,) float
        Square metres each stands for.
    part : (n,) int
        Index into ``Scene.parts``.
    kind : (n,) int
        FACADE, ROOF, TERRACE or OPPOSED_TERRACE.
    spacing : float
        Metres.
    left_out : dict of str to float
        Square metres left out, by cause.
    flipped_normals : int
        Samples whose face pointed inward.
    """

    points: np.ndarray
    normals: np.ndarray
    area: np.ndarray
    part: np.ndarray  # index into Scene.parts
    kind: np.ndarray  # FACADE / ROOF / TERRACE / OPPOSED_TERRACE
    spacing: float
    left_out: dict[str, float] = field(default_factory=dict)  # cause -> m^2
    flipped_normals: int = 0  # samples whose face pointed inward (open meshes)

    def __len__(self) -> int:
        return len(self.points)

    @property
    def total_area(self) -> float:
        """Square metres of surface the samples stand for."""
        return float(self.area.sum())

    def subset(self, mask) -> "SurfaceSamples":
        """The samples ``mask`` selects.

        Parameters
        ----------
        mask : (n,) bool or (k,) int
            Samples to keep.

        Returns
        -------
        SurfaceSamples
            A new set.
        """
        return SurfaceSamples(self.points[mask], self.normals[mask], self.area[mask],
                              self.part[mask], self.kind[mask], self.spacing, dict(self.left_out),
                              self.flipped_normals)

    def of_classes(self, names) -> "SurfaceSamples":
        """The samples of some classes (facade, roof, terrace, opposed_terrace).

        Parameters
        ----------
        names : sequence of str
            Class names.

        Returns
        -------
        SurfaceSamples
            A new set.
        """
        unknown = set(names) - set(CLASS_NAMES)
        if unknown:
            raise ParameterError(f"unknown surface class {', '.join(sorted(unknown))}; classes: {', '.join(CLASS_NAMES)}")
        return self.subset(np.isin(self.kind, [CLASS_NAMES.index(c) for c in names]))

    def class_areas(self) -> dict[str, float]:
        """Square metres per surface class.

        Returns
        -------
        dict of str to float
            Every class, zero where it has no sample.
        """
        return {name: float(self.area[self.kind == k].sum()) for k, name in enumerate(CLASS_NAMES)}


def default_spacing(scene, d_opt: float, max_samples: int = 30_000) -> float:
    """A sample spacing of d_opt / 8, coarsened so the target gives at most ``max_samples``.

    Parameters
    ----------
    scene : Scene
        The scene.
    d_opt : float
        Metres.
    max_samples : int
        The most samples.

    Returns
    -------
    float
        Metres.
    """
    area = sum(p.mesh.area for p in scene.targets)
    return float(max(d_opt / 8.0, np.sqrt(area / max_samples), 0.02))


# The fine resolution at which coverage is checked (planner's repair loop, evaluator's
# default): halving it changed coverage by < 0.05 pp on the sample scenes (docs/coverage.md).
CHECK_SPACING_M = 0.25
MAX_CHECK_SAMPLES = 400_000


def check_spacing(scene, spacing: float | None = None) -> float:
    """``spacing`` (default 0.25 m), coarsened so the target gives at most 400,000 samples.

    Parameters
    ----------
    scene : Scene
        The scene.
    spacing : float, optional
        Metres.

    Returns
    -------
    float
        Metres.
    """
    area = sum(p.mesh.area for p in scene.targets)
    wanted = CHECK_SPACING_M if spacing is None else check_positive("spacing", spacing)
    return float(max(wanted, np.sqrt(area / MAX_CHECK_SAMPLES)))


def sample_surface(scene, spacing: float, seed: int = 0, oversample: float = 6.0) -> SurfaceSamples:
    """Sample the target surface about every ``spacing`` metres.

    Faces resting on the ground, surface below the ground and surface buried inside another
    mesh (or inside the target itself) are left out; their areas are in ``left_out``.

    Parameters
    ----------
    scene : Scene
        The scene.
    spacing : float
        Metres.
    seed : int
        The sampling's seed.
    oversample : float
        Points drawn per sample kept.

    Returns
    -------
    SurfaceSamples
        The samples.
    """
    spacing = check_positive("spacing", spacing)
    rng = np.random.default_rng(seed)
    # Ground contact: facing down (within 45 deg: scans are bumpy) and centred within 10 cm (or
    # 0.5 % of the height) of the ground, which the lowest, noisiest vertex sets.
    tol = max(0.1, 5e-3 * float(np.ptp(scene.bounds("target")[:, 2])))
    left_out = {"ground": 0.0, "below_ground": 0.0, "buried": 0.0}
    tri, normals, owner = [], [], []
    for index in scene.target_indices:
        mesh = scene.parts[index].mesh
        on_ground = ((mesh.face_normals[:, 2] < -0.7)
                     & (mesh.triangles_center[:, 2] <= scene.ground_at(mesh.triangles_center[:, :2]) + tol))
        left_out["ground"] += float(mesh.area_faces[on_ground].sum())
        keep = ~on_ground
        tri.append(mesh.triangles[keep])
        normals.append(mesh.face_normals[keep])
        owner.append(np.full(int(keep.sum()), index))
    tri, normals, owner = np.concatenate(tri), np.concatenate(normals), np.concatenate(owner)
    areas = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    total = float(areas.sum())
    if total <= 0:
        raise PlanningError("the target has no surface to image (all faces rest on the ground)")
    n_dense = int(min(max(np.ceil(oversample * total / spacing ** 2), 64), _MAX_DENSE))
    face = np.searchsorted(np.cumsum(areas) / total, rng.random(n_dense), side="right")
    face = np.minimum(face, len(areas) - 1)
    u, v = rng.random(n_dense), rng.random(n_dense)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    t = tri[face]
    dense = t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0])
    dense_area = total / n_dense

    # Terrain is an opaque surface: whatever lies under it is hidden, however little.
    below = dense[:, 2] < scene.ground_at(dense[:, :2]) - (0.0 if scene.terrain is not None else tol)
    left_out["below_ground"] = float(below.sum() * dense_area)
    dense, face = dense[~below], face[~below]
    if len(dense) == 0:
        raise PlanningError("the target has no surface above the ground")

    # One sample per (cell, normal direction, part): the dense point nearest the cell's mean.
    cell = np.floor(dense / spacing).astype(np.int64)
    bucket = np.argmax(normals @ _BUCKETS.T, axis=1)[face]
    key = np.column_stack([cell - cell.min(axis=0), bucket, owner[face]])
    dims = key.max(axis=0) + 1
    if np.prod(dims.astype(float)) < 2.0 ** 62:  # one int64 per key: unique on scalars sorts far faster
        _, group, counts = np.unique(np.ravel_multi_index(key.T, dims), return_inverse=True, return_counts=True)
    else:
        _, group, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    group = group.ravel()
    means = np.column_stack([np.bincount(group, weights=dense[:, k], minlength=len(counts))
                             for k in range(3)]) / counts[:, None]
    off = np.linalg.norm(dense - means[group], axis=1)
    # Per group the nearest point (the lowest index among ties), without sorting all of them.
    least = np.full(len(counts), np.inf)
    np.minimum.at(least, group, off)
    ties = np.flatnonzero(off == least[group])
    first = np.full(len(counts), len(off))
    np.minimum.at(first, group[ties], ties)
    points, sample_face = dense[first], face[first]
    sample_area = counts[group[first]] * dense_area
    sample_normals = normals[sample_face]
    sample_part = owner[sample_face]

    # Parts that are not closed solids may have faces turned inward: keep each sample's normal
    # on the side its own part's ray parity calls outside.
    step = scene.epsilon * 4
    open_parts = np.array([not p.mesh.is_watertight for p in scene.parts], dtype=bool)
    rows = np.flatnonzero(open_parts[sample_part])
    flipped = 0
    if len(rows):
        ahead = scene.rays.inside_each(points[rows] + sample_normals[rows] * step)[np.arange(len(rows)), sample_part[rows]]
        behind = scene.rays.inside_each(points[rows] - sample_normals[rows] * step)[np.arange(len(rows)), sample_part[rows]]
        flip = rows[ahead & ~behind]
        sample_normals[flip] *= -1
        flipped = len(flip)
    # Buried: just off the surface, on its outer side, is inside some mesh.
    buried = scene.rays.inside(points + sample_normals * step) >= 0
    left_out["buried"] = float(sample_area[buried].sum())
    keep = ~buried
    if not keep.any():
        raise PlanningError("the whole target surface is buried inside other meshes")
    samples = SurfaceSamples(points[keep], sample_normals[keep], sample_area[keep],
                             sample_part[keep], np.zeros(int(keep.sum()), dtype=np.int8), spacing,
                             {k: v for k, v in left_out.items() if v > 0}, flipped_normals=flipped)
    samples.kind = classify(samples.points, samples.normals, scene)
    return samples


def classify(points, normals, scene) -> np.ndarray:
    """Facade / roof / terrace / opposed terrace per sample, from normals and surroundings.

    Up-facing samples are terraces when, looking horizontally from just above them, some
    direction meets a wall of the target (the building goes on above them); else roof.

    Parameters
    ----------
    points, normals : (n, 3) float
        Samples.
    scene : Scene
        The scene.

    Returns
    -------
    (n,) int
        FACADE, ROOF, TERRACE or OPPOSED_TERRACE.
    """
    points = np.asarray(points, dtype=float)
    normals = np.asarray(normals, dtype=float)
    kind = np.full(len(points), FACADE, dtype=np.int8)
    up = normals[:, 2] >= FACADE_MAX_NZ
    kind[normals[:, 2] <= -FACADE_MAX_NZ] = OPPOSED_TERRACE
    kind[up] = ROOF
    idx = np.flatnonzero(up)
    if len(idx) == 0:
        return kind
    angles = np.radians(np.arange(0, 360, 45))
    dirs = np.column_stack([np.sin(angles), np.cos(angles), np.zeros_like(angles)])
    lift = max(scene.epsilon * 10, 0.05)
    origins = np.repeat(points[idx] + normals[idx] * lift, len(dirs), axis=0)
    _dist, mesh, face = scene.rays.first_hit(origins, np.tile(dirs, (len(idx), 1)))
    wall = np.zeros(len(origins), dtype=bool)
    is_target = np.isin(mesh, scene.target_indices)
    for m in np.unique(mesh[is_target]):
        sel = np.flatnonzero(mesh == m)
        nz = scene.parts[m].mesh.face_normals[face[sel], 2]
        wall[sel] = np.abs(nz) < FACADE_MAX_NZ
    kind[idx[wall.reshape(len(idx), len(dirs)).any(axis=1)]] = TERRACE
    return kind
