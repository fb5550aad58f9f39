"""Can any safe position image a surface point? Probes in the incidence cone answer it.

For each sample we try positions along directions within ``max_incidence_deg`` of its
normal, at ranges between the security distance and d_opt. A probe works when it is above
the minimum altitude, its line of sight to the sample is clear, the gimbal can aim at the
sample from there, and it keeps the security distance from every mesh. A clear line of
sight from the outer side of the surface also proves the probe is outside every mesh.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from coverplan.shots.limits import ViewLimits
from coverplan.world.zones import KEEP_OUT, Zones

OK, LOW, GIMBAL, OCCLUDED, UNSAFE, HIGH, ZONED = 0, 1, 2, 3, 4, 5, 6
GROUND = -2  # culprit index meaning the ground plane


def cone_directions(half_angle_deg: float, count: int) -> np.ndarray:
    """``count`` unit vectors spread over the cap of half-angle ``half_angle_deg`` about +z.

    Parameters
    ----------
    half_angle_deg : float
        The cap's half-angle.
    count : int
        Directions.

    Returns
    -------
    (count, 3) float
        Unit vectors, +z first.
    """
    k = np.arange(count) + 0.5
    cos_min = np.cos(np.radians(half_angle_deg))
    z = 1.0 - (1.0 - cos_min) * k / count
    phi = k * np.pi * (3.0 - np.sqrt(5.0))
    r = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    cap = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
    return np.vstack([[0.0, 0.0, 1.0], cap])


def tangent_frames(normals) -> tuple[np.ndarray, np.ndarray]:
    """Two unit tangents per normal, so (t1, t2, n) is right-handed.

    Parameters
    ----------
    normals : (n, 3) float
        Unit normals.

    Returns
    -------
    t1, t2 : (n, 3) float
        Unit tangents.
    """
    normals = np.asarray(normals, dtype=float)
    helper = np.where(np.abs(normals[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    t1 = np.cross(helper, normals)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    return t1, np.cross(normals, t1)


def probe_positions(points, normals, sample_index, limits: ViewLimits, directions: np.ndarray,
                    range_fractions) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Probe positions for the given samples: (sample index, position, unit ray) per probe.

    Parameters
    ----------
    points, normals : (n, 3) float
        Samples.
    sample_index : (k,) int
        The samples probed.
    limits : ViewLimits
        Gives d_opt.
    directions : (m, 3) float
        Probe directions in each sample's tangent frame.
    range_fractions : sequence of float
        Shares of d_opt.

    Returns
    -------
    owner : (p,) int
        The sample of each probe.
    positions : (p, 3) float
        Probe positions.
    rays : (p, 3) float
        Unit rays, sample to probe.
    """
    sample_index = np.asarray(sample_index, dtype=np.int64)
    t1, t2 = tangent_frames(normals[sample_index])
    n = normals[sample_index]
    world = (directions[None, :, 0:1] * t1[:, None] + directions[None, :, 1:2] * t2[:, None]
             + directions[None, :, 2:3] * n[:, None])  # (S, D, 3)
    ranges = limits.security + (limits.d_opt - limits.security) * np.asarray(range_fractions, float)
    pos = points[sample_index][:, None, None, :] + world[:, :, None, :] * ranges[None, None, :, None]
    rays = np.broadcast_to(world[:, :, None, :], pos.shape)
    owner = np.broadcast_to(sample_index[:, None, None], pos.shape[:3])
    return owner.reshape(-1), pos.reshape(-1, 3), rays.reshape(-1, 3)


def test_probes(scene, points, normals, owner, positions, rays, limits: ViewLimits):
    """Status per probe (OK / LOW / GIMBAL / OCCLUDED / UNSAFE) and the mesh that caused it.

    Parameters
    ----------
    scene : Scene
        The scene.
    points, normals : (n, 3) float
        Samples.
    owner : (p,) int
        The sample of each probe.
    positions : (p, 3) float
        Probe positions.
    rays : (p, 3) float
        Unit rays, sample to probe.
    limits : ViewLimits
        The viewpoint rules.

    Returns
    -------
    status : (p,) int
        OK, LOW, GIMBAL, OCCLUDED or UNSAFE.
    culprit : (p,) int
        The mesh that blocked or came too close, -1 where none.
    """
    status = np.full(len(positions), OK, dtype=np.int8)
    culprit = np.full(len(positions), -1, dtype=np.int64)
    # The gimbal first: a probe the gimbal cannot aim from is GIMBAL at any altitude, so LOW
    # means "the gimbal could, the altitude floor forbids it" and the two reasons stay apart.
    status[~limits.elevation_ok(rays)] = GIMBAL
    status[(status == OK) & ~limits.above_floor(positions, tol=0.0)] = LOW
    status[(status == OK) & ~limits.below_ceiling(positions, tol=0.0)] = HIGH
    if limits.zones:
        live = np.flatnonzero(status == OK)
        breach = limits.zones.point_breaches(positions[live])
        status[live[breach >= 0]] = ZONED
        culprit[live[breach >= 0]] = breach[breach >= 0]
    start = points[owner] + normals[owner] * scene.epsilon * 4
    blocked = scene.rays.segments_blocked(start, positions)
    status[blocked] = OCCLUDED
    underground = ~blocked & (positions[:, 2] < limits.ground_at(positions[:, :2]))  # the ground is opaque too
    status[underground] = OCCLUDED
    culprit[underground] = GROUND
    # Zoned probes are judged on the rest too: "only from the zone" must mean the zone alone.
    live = np.flatnonzero((status == OK) | (status == ZONED))
    if len(live):
        clearance = scene.clearance_model(limits.security)
        safe = clearance.points_clear(positions[live], limits.security, check_inside=False)
        status[live[~safe]] = UNSAFE
        culprit[live[~safe]] = clearance.kd_distance(positions[live[~safe]], limits.security * 2)[1]
    occ = np.flatnonzero(blocked)  # which mesh is in the way
    if len(occ):
        length = np.linalg.norm(positions[occ] - start[occ], axis=1)
        _d, mesh, _f = scene.rays.first_hit(start[occ], positions[occ] - start[occ], max_distance=length)
        culprit[occ] = mesh
    return status, culprit


@dataclass
class Reachability:
    """Which samples some safe viewpoint can image, and why not for the others.

    Parameters
    ----------
    reachable : (n,) bool
        Per sample.
    reason : list of str
        Per sample: empty when reachable, else why not.
    """
    reachable: np.ndarray  # bool per sample
    reason: list  # per sample: "" when reachable, else why not

    def with_witnesses(self, imaged: np.ndarray) -> "Reachability":
        """Also reachable: samples some known safe viewpoint images (the probes only sample
        the positions, so a real viewpoint can prove one they missed).

        Parameters
        ----------
        imaged : (n,) bool
            Samples a safe viewpoint images.

        Returns
        -------
        Reachability
            A new verdict.
        """
        found = np.asarray(imaged, dtype=bool) & ~self.reachable
        reason = [("" if f else r) for f, r in zip(found, self.reason)]
        return Reachability(self.reachable | found, reason)


def reachability(scene, samples, limits: ViewLimits, n_directions: int = 48,
                 range_fractions=(0.1, 0.4, 0.7, 1.0), known=None) -> Reachability:
    """Which samples some safe position within d_opt can image, and why not for the rest.
    Samples ``known`` to be reachable (a safe viewpoint images them) are not probed.

    Parameters
    ----------
    scene : Scene
        The scene.
    samples : SurfaceSamples
        The samples.
    limits : ViewLimits
        The viewpoint rules.
    n_directions : int
        Probe directions per sample.
    range_fractions : sequence of float
        Shares of d_opt probed.
    known : (n,) bool, optional
        Samples already known to be reachable.

    Returns
    -------
    Reachability
        The verdict.
    """
    points, normals = samples.points, samples.normals
    n = len(points)
    reachable = np.zeros(n, dtype=bool) if known is None else np.array(known, dtype=bool)
    # Stage 1: straight out along the normal at mid range settles most samples.
    everyone = np.flatnonzero(~reachable)
    owner, pos, rays = probe_positions(points, normals, everyone, limits, np.array([[0.0, 0.0, 1.0]]),
                                       [0.5])
    status, _ = test_probes(scene, points, normals, owner, pos, rays, limits)
    reachable[owner[status == OK]] = True
    # Stage 2: the whole cone for the rest.
    rest = np.flatnonzero(~reachable)
    reason = [""] * n
    if len(rest):
        owner, pos, rays = probe_positions(points, normals, rest, limits,
                                           cone_directions(limits.max_incidence_deg * 0.995, n_directions),
                                           range_fractions)
        status, culprit = test_probes(scene, points, normals, owner, pos, rays, limits)
        reachable[owner[status == OK]] = True
        for s in np.flatnonzero(~reachable[rest]):
            k = rest[s]
            mine = owner == k
            reason[k] = explain(scene, status[mine], culprit[mine], limits.zones)
    return Reachability(reachable, reason)


def explain(scene, status, culprit, zones: Zones = Zones()) -> str:
    """One line saying why none of a sample's probes worked (a zone first: without it the
    sample would be reachable).

    Parameters
    ----------
    scene : Scene
        Names the meshes.
    status : (m,) int
        The sample's probes' status.
    culprit : (m,) int
        Their culprits.
    zones : Zones
        Zones, checked first.

    Returns
    -------
    str
        The reason.
    """
    def most_common(mask):
        c = culprit[mask & (culprit != -1)]
        if len(c) == 0:
            return "a mesh"
        values, counts = np.unique(c, return_counts=True)
        top = int(values[np.argmax(counts)])
        return scene.describe(len(scene.parts)) if top == GROUND else scene.describe(top)
    zoned = status == ZONED
    if zoned.any():
        values, counts = np.unique(culprit[zoned], return_counts=True)
        zone = zones.zones[int(values[np.argmax(counts)])]
        return (f"reachable only from {zone.label}" if zone.kind == KEEP_OUT
                else f"reachable only from outside {zone.label}")
    if (status == UNSAFE).any():
        unsafe = f"no viewpoint within d_opt keeps the security distance from {most_common(status == UNSAFE)}"
        # Both: the blocker in front and what crowds the way around it (often the same tree).
        return f"occluded by {most_common(status == OCCLUDED)}; {unsafe}" if (status == OCCLUDED).any() else unsafe
    low, gimbal = (status == LOW).any(), (status == GIMBAL).any()
    if (status == HIGH).any() and not low:
        return "visible only from above the altitude ceiling" + (
            " or at a gimbal pitch outside its range" if gimbal else "")
    if low and gimbal:  # either setting may be what blocks: say both
        return "visible only from below the minimum altitude or at a gimbal pitch outside its range"
    if low:
        return "visible only from below the minimum altitude"
    if gimbal:
        return "visible only at a gimbal pitch outside its range"
    return f"occluded by {most_common(status == OCCLUDED)}"
