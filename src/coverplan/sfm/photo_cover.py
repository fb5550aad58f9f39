"""What a model's registered photos see of the target, where its sparse points are too thin to
judge at the judging radius.

COLMAP's sparse model holds a few thousand points; on a small building photographed from a
few metres that is hundreds per square metre, but on a large site flown from 40 m it is one
point every few square metres, and no sample can have a point within 0.2 m however good the
flight. What such a flight gives at most is what a dense reconstruction would rebuild: the
surface its registered photos see, unoccluded, from two views or more. ``photo_cover`` counts
that from the photos' own SfM poses (aligned to the scene, and fitted where the fit was kept).
"""

from __future__ import annotations

import numpy as np

MAX_INCIDENCE_DEG = 75.0  # a view more grazing than this rebuilds little, densely or not
MAX_SAMPLES = 60_000  # judged on at most this many samples (a random, fixed subset)


def point_ceiling(points: int, area_m2: float, radius_m: float) -> float:
    """The most surface ``points`` 3D points can put within ``radius_m`` of a sample.

    Parameters
    ----------
    points : int
        3D points in the model.
    area_m2 : float
        The surface judged, m².
    radius_m : float
        The judging radius, m: each point reaches a disc of that radius at best.

    Returns
    -------
    float
        Percent of ``area_m2``, at most 100.
    """
    if area_m2 <= 0:
        return 100.0
    return float(min(100.0, 100.0 * points * np.pi * radius_m ** 2 / area_m2))


def photo_cover(model, samples, rays, fit: np.ndarray | None = None, min_views: int = 2,
                max_incidence_deg: float = MAX_INCIDENCE_DEG, seed: int = 0) -> dict:
    """Share of the target that the model's registered photos see from ``min_views`` or more.

    Parameters
    ----------
    model : SfmModel
        An aligned model with its photos' rotations and pinhole intrinsics.
    samples : SurfaceSamples
        The judging samples (n of them): points, normals, area, kind.
    rays : RayCaster
        The scene's meshes, for occlusion.
    fit : (4, 4) float, optional
        The rigid fit applied to the model's points after alignment (None: none).
    min_views : int
        Photos a sample must be seen by.
    max_incidence_deg : float
        Widest angle between a view and the sample's normal that counts.
    seed : int
        Seed of the subset judged when there are more than ``MAX_SAMPLES`` samples.

    Returns
    -------
    dict
        ``pct``: the share of the surface area seen so (%); ``by_class_pct`` per judge class;
        ``views``: (m,) int views of each judged sample; ``judged``: (m,) int indices into the
        samples.
    """
    from coverplan.sfm.judge import judge_classes

    n = len(samples.points)
    judged = np.arange(n) if n <= MAX_SAMPLES else np.sort(
        np.random.default_rng(seed).choice(n, MAX_SAMPLES, replace=False))
    pts, normals, area = samples.points[judged], samples.normals[judged], samples.area[judged]
    centres, rotations = np.asarray(model.centres, float), np.asarray(model.rotations, float)
    if fit is not None:
        centres = centres @ fit[:3, :3].T + fit[:3, 3]
        rotations = rotations @ fit[:3, :3].T
    cos_max = np.cos(np.radians(max_incidence_deg))
    cam_list, pt_list = [], []
    for k in range(len(centres)):  # one camera at a time, every sample at once
        fx, fy, cx, cy, w, h = model.intrinsics[k]
        rel = pts - centres[k]
        local = rel @ rotations[k].T
        z = local[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u, v = fx * local[:, 0] / z + cx, fy * local[:, 1] / z + cy
        dist = np.linalg.norm(rel, axis=1)
        facing = -(rel * normals).sum(axis=1) / np.maximum(dist, 1e-9)
        ok = (z > 0) & (u >= 0) & (u < w) & (v >= 0) & (v < h) & (facing >= cos_max)
        hit = np.flatnonzero(ok)
        cam_list.append(np.full(len(hit), k))
        pt_list.append(hit)
    cam = np.concatenate(cam_list) if cam_list else np.zeros(0, int)
    pt = np.concatenate(pt_list) if pt_list else np.zeros(0, int)
    if len(pt):
        ends = pts[pt] + 0.02 * normals[pt]  # just off the surface, so its own face does not hide it
        clear = ~rays.segments_blocked(centres[cam], ends)
        views = np.bincount(pt[clear], minlength=len(pts))
    else:
        views = np.zeros(len(pts), dtype=int)
    seen = views >= min_views
    classes = judge_classes(normals, samples.kind[judged])
    by_class = {c: float(100.0 * area[seen & (classes == c)].sum() / max(area[classes == c].sum(), 1e-12))
                for c in sorted(set(classes))}
    return {"pct": float(100.0 * area[seen].sum() / max(area.sum(), 1e-12)), "by_class_pct": by_class,
            "views": views, "judged": judged}
