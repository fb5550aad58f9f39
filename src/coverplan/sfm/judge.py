"""What a reconstruction recovered: the share of the target surface with a 3D point nearby.

The surface is sampled afresh (own seed, fine spacing), so the verdict does not rest on
the planner's samples. Classes: façades by the compass direction they face, roofs,
terraces and undersides (the thesis's opposed terraces).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from coverplan.shots.surface import (
    FACADE,
    OPPOSED_TERRACE,
    ROOF,
    TERRACE,
    sample_surface,
)

JUDGE_SEED = 7919
MAX_JUDGE_SAMPLES = 300_000
_COMPASS = ("north", "east", "south", "west")


def judge_classes(normals: np.ndarray, kind: np.ndarray) -> np.ndarray:
    """A class name per sample: 'facade north' ... 'facade west', 'roof', 'terrace', 'underside'.

    Parameters
    ----------
    normals : (n, 3) float
        Unit outward normals of the samples.
    kind : (n,) int
        The samples' surface kinds (shots/surface.py: FACADE, ROOF, TERRACE, OPPOSED_TERRACE).

    Returns
    -------
    (n,) object
        The class names; a façade's compass side is where its normal points.
    """
    azimuth = np.degrees(np.arctan2(normals[:, 0], normals[:, 1])) % 360.0
    compass = np.array([f"facade {c}" for c in _COMPASS])[((azimuth + 45.0) // 90.0).astype(int) % 4]
    names = np.where(kind == FACADE, compass, "")
    names = np.where(kind == ROOF, "roof", names)
    names = np.where(kind == TERRACE, "terrace", names)
    return np.where(kind == OPPOSED_TERRACE, "underside", names).astype(object)


def judge_samples(scene, spacing: float):
    """Fresh target samples for judging, the spacing coarsened to stay under a size cap.

    Parameters
    ----------
    scene : Scene
        The targets are sampled.
    spacing : float
        Wanted spacing, m; coarsened so that at most ``MAX_JUDGE_SAMPLES`` are drawn.

    Returns
    -------
    SurfaceSamples
        Drawn with the judge's own seed, not the planner's.
    """
    area = sum(p.mesh.area for p in scene.targets)
    spacing = max(float(spacing), float(np.sqrt(area / MAX_JUDGE_SAMPLES)))
    return sample_surface(scene, spacing, seed=JUDGE_SEED)


def reconstructed_surface(samples, points: np.ndarray, radii=(0.1, 0.2)) -> dict:
    """Per radius: % of the surface area with a 3D point within it, overall and per class,
    plus the per-sample distance to the nearest point (for pictures).

    Parameters
    ----------
    samples : SurfaceSamples
        The judging samples (n of them).
    points : (m, 3) float
        The model's 3D points in the scene's frame.
    radii : tuple of float
        Judging radii, m.

    Returns
    -------
    dict
        ``by_radius`` {str(radius): {"pct", "by_class_pct"}}, ``class_area_m2``,
        ``sample_spacing_m``, ``samples``, ``classes`` (n,) object, and ``nearest_point_m``
        (n,) float: each sample's distance to the nearest point (inf beyond four times the
        largest radius).
    """
    if len(points):
        dist, _ = cKDTree(points).query(samples.points, k=1, distance_upper_bound=max(radii) * 4)
    else:
        dist = np.full(len(samples), np.inf)
    classes = judge_classes(samples.normals, samples.kind)
    total = samples.area.sum()
    out = {"sample_spacing_m": samples.spacing, "samples": int(len(samples)), "by_radius": {},
           "class_area_m2": {c: float(samples.area[classes == c].sum()) for c in sorted(set(classes))}}
    for r in radii:
        hit = dist <= r
        out["by_radius"][f"{r:g}"] = {
            "pct": 100.0 * float(samples.area[hit].sum() / total) if total else 0.0,
            "by_class_pct": {c: 100.0 * float(samples.area[hit & (classes == c)].sum()
                                             / samples.area[classes == c].sum())
                             for c in sorted(set(classes))},
        }
    out["nearest_point_m"] = dist
    out["classes"] = classes
    return out
