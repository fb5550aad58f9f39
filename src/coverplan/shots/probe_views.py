"""Candidates from probes: working reachability probes aimed at the samples only grazing or narrow views reach."""

from __future__ import annotations

import numpy as np

from coverplan.runs import run_offsets
from coverplan.shots.candidates import Candidates
from coverplan.shots.limits import ViewLimits
from coverplan.shots.reachability import OK, cone_directions, probe_positions, tangent_frames, test_probes


def from_probes(scene, samples, needy, limits: ViewLimits, per_sample: int = 8,
                n_directions: int = 96, range_fractions=(0.1, 0.35, 0.6, 0.85, 0.97)) -> Candidates:
    """Working reachability probes of the ``needy`` samples, aimed at their sample.

    The cone reaches out to the incidence limit, as the evaluator's reachability does: these
    are the samples only grazing views can reach.

    Parameters
    ----------
    scene : Scene
        The scene.
    samples : SurfaceSamples
        The samples.
    needy : (k,) int
        The samples that need views.
    limits : ViewLimits
        The viewpoint rules.
    per_sample : int
        The most cameras per sample.
    n_directions : int
        Probe directions.
    range_fractions : sequence of float
        Shares of d_opt probed along each direction.

    Returns
    -------
    Candidates
        The cameras.
    """
    needy = np.asarray(needy, dtype=np.int64)
    if len(needy) == 0:
        return Candidates.empty()
    directions = cone_directions(limits.max_incidence_deg * 0.995, n_directions)
    owner, pos, rays = probe_positions(samples.points, samples.normals, needy, limits, directions,
                                       range_fractions)
    status, _ = test_probes(scene, samples.points, samples.normals, owner, pos, rays, limits)
    good = np.flatnonzero(status == OK)
    # Keep a spread of directions per sample.
    keep = good[spread_per_owner(owner[good], per_sample)]
    if len(keep) == 0:
        return Candidates.empty()
    return Candidates.looking(pos[keep], -rays[keep], limits, source=2)


def around_views(scene, samples, owner, cameras, limits: ViewLimits, tilts_deg=(2.5, 5.0), n_azimuths: int = 8,
                 range_fractions=(0.5, 0.75, 0.95), per_sample: int = 10) -> Candidates:
    """Working probes in a narrow cone around known views of samples, aimed at their sample.

    ``owner[k]`` is the sample that the camera at ``cameras[k]`` images. Where the safe
    viewpoints of a sample fill a cone a few degrees wide (a wall foot seen only between two
    obstacles), the reachability probes' cone, 8 degrees between neighbours at 192
    directions, rarely puts two of them inside; a second view 5 degrees off the first does.

    Parameters
    ----------
    scene : Scene
        The scene.
    samples : SurfaceSamples
        The samples.
    owner : (k,) int
        The sample each known camera images.
    cameras : (k, 3) float
        Known camera centres.
    limits : ViewLimits
        The viewpoint rules.
    tilts_deg : sequence of float
        Cone half-angles around each known view.
    n_azimuths : int
        Directions per cone.
    range_fractions : sequence of float
        Shares of d_opt probed.
    per_sample : int
        The most cameras per sample.

    Returns
    -------
    Candidates
        The cameras.
    """
    owner = np.asarray(owner, dtype=np.int64)
    if len(owner) == 0:
        return Candidates.empty()
    base = cameras - samples.points[owner]
    base /= np.linalg.norm(base, axis=1, keepdims=True)
    t1, t2 = tangent_frames(base)
    az = np.radians(np.arange(n_azimuths) * 360.0 / n_azimuths)
    tilt = np.radians(np.asarray(tilts_deg, float))
    a, t = (g.ravel() for g in np.meshgrid(az, tilt))
    off = (np.sin(t)[None, :, None] * (np.cos(a)[None, :, None] * t1[:, None] + np.sin(a)[None, :, None] * t2[:, None])
           + np.cos(t)[None, :, None] * base[:, None])  # (views, offsets, 3)
    ranges = limits.security + (limits.d_opt - limits.security) * np.asarray(range_fractions, float)
    rays = np.repeat(off[:, :, None], len(ranges), axis=2)
    pos = samples.points[owner][:, None, None] + rays * ranges[None, None, :, None]
    who = np.broadcast_to(owner[:, None, None], rays.shape[:3]).reshape(-1)
    rays, pos = rays.reshape(-1, 3), pos.reshape(-1, 3)
    facing = np.einsum("ij,ij->i", rays, samples.normals[who]) >= np.cos(np.radians(limits.max_incidence_deg * 0.995))
    who, rays, pos = who[facing], rays[facing], pos[facing]
    status, _ = test_probes(scene, samples.points, samples.normals, who, pos, rays, limits)
    good = np.flatnonzero(status == OK)
    good = good[spread_per_owner(who[good], per_sample)]
    return Candidates.looking(pos[good], -rays[good], limits, source=2)


def spread_per_owner(owner: np.ndarray, k: int) -> np.ndarray:
    """Indices keeping at most ``k`` entries per owner, evenly spread over each owner's
    entries (in their order): per owner ``np.linspace(0, n - 1, min(k, n)).astype(int)``,
    owners ascending.

    Parameters
    ----------
    owner : (n,) int
        The owner of each entry.
    k : int
        The most entries per owner.

    Returns
    -------
    (m,) int
        Indices into ``owner``.
    """
    order = np.argsort(owner, kind="stable")
    sorted_owner = owner[order]
    first = np.flatnonzero(np.r_[True, sorted_owner[1:] != sorted_owner[:-1]]) if len(owner) else np.zeros(0, int)
    n = np.diff(np.r_[first, len(owner)])
    take = np.minimum(n, k)
    group = np.repeat(np.arange(len(first)), take)
    i = run_offsets(take)
    # linspace's arithmetic exactly: i * ((n - 1) / (take - 1)), the last one n - 1 (one: the first).
    div = np.maximum(take[group] - 1, 1)
    at = (i * ((n[group] - 1) / div)).astype(np.int64)
    last = (i == take[group] - 1) & (take[group] > 1)
    at[last] = n[group][last] - 1
    return order[first[group] + at]
