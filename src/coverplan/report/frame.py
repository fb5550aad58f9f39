"""What the pictures frame: the target, its flight and what lies within the flight's reach,
not the whole city tile the obstacles came from."""

from __future__ import annotations

import numpy as np


def focus_bounds(route, scene) -> tuple[np.ndarray, np.ndarray]:
    """Box around the target and every waypoint, padded by the security distance plus a few
    metres; obstacles beyond it are cut off by the picture's edge."""
    lo, hi = scene.bounds("target")
    lo = np.minimum(lo, route.positions.min(axis=0))
    hi = np.maximum(hi, route.positions.max(axis=0))
    pad = route.security + 5.0
    lo, hi = lo - pad, hi + pad
    lo[2] = min(lo[2] + pad, float(scene.ground_z))  # down to the ground, no further
    return lo, hi
