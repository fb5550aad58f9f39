"""Lanes for walls the wrapped rings only graze: the sides and the back of a notch.

- across lanes: a wall facing another wall of the building a short way off (the sides of a
  notch, the walls of a courtyard). A level lane at the standoff does not fit in a gap
  narrower than twice the standoff, and from outside the gap such walls are seen at grazing
  incidence; one straight lane per such façade flies along it over the far wall's top edge
  (``ACROSS_REACH``), the nearest distance above the target's top, looking back across the gap
  and down at the façade's mid-height (``across_lanes``);
- recess lanes: a wall set back from the building's convex hull (a notch's back wall), whose
  outward view meets no wall. The wrapped rings pivot in place at the notch's mouth; one level
  lane flies across the mouth, the recess's depth and the nearest distance out (``recess_lanes``).

Both are clipped afterwards as every lane is (``safe_lanes``); the cover takes what they add.
"""

from __future__ import annotations

import numpy as np
import shapely

from coverplan.shots.candidates import Candidates, _rings, _section_union
from coverplan.shots.lanes import (
    FORWARD_OVERLAP,
    LANE_SOURCE,
    OVERRUN,
    SIDE_OVERLAP,
    Lanes,
    _facades,
    _run_photos,
    band_heights,
    lane_steps,
)
from coverplan.shots.limits import ViewLimits

ACROSS_REACH = 0.0  # the lane runs this share of the nearest distance beyond the far wall (0: over its top edge)
GAP_SHARES = 2.0  # a façade is across-lit when the wall it faces is nearer than this many standoffs
MERGE_M = 0.5  # façades on one line (and gaps) within this are flown as one lane


def facing_gaps(section, runs: list[tuple[np.ndarray, bool]], reach: float) -> np.ndarray:
    """How far each façade's midpoint looks, along its outward normal, to the next wall of
    ``section``; ``inf`` past ``reach``.

    Parameters
    ----------
    section : shapely geometry
        The target's section.
    runs : list of ((m, 2) float, bool)
        Façades as ``_facades`` gives them.
    reach : float
        Metres looked along.

    Returns
    -------
    (len(runs),) float
        Metres, or inf.
    """
    if not runs:
        return np.zeros(0)
    mids, normals = zip(*[_midpoint(run) for run in runs])
    mids, normals = np.array(mids), np.array(normals)
    start = mids + 1e-3 * normals
    rays = shapely.linestrings(np.stack([start, mids + reach * normals], axis=1))
    hits = shapely.intersection(rays, section.boundary)
    gap = shapely.distance(shapely.points(start), hits)
    return np.where(shapely.is_empty(hits) | ~np.isfinite(gap), np.inf, gap + 1e-3)


def _midpoint(run: tuple[np.ndarray, bool]) -> tuple[np.ndarray, np.ndarray]:
    """The point halfway along a façade and its outward normal there (``_run_photos`` with no
    step limit places one photo, at the middle)."""
    xy, normal = _run_photos(run, np.inf, 0.0, 0.0)
    return (xy[0], normal[0]) if len(xy) else (np.zeros(2), np.zeros(2))


def _flanked(section, run: tuple[np.ndarray, bool], probe: float = 0.1) -> bool:
    """Whether the walls at both ends of a façade turn outward: a point ``probe`` m past
    each end, along the façade and ``probe`` m out from it, lies inside the section."""
    xy = np.asarray(run[0], float)
    _, normal = _midpoint(run)
    first = (xy[0] - xy[1]) / np.linalg.norm(xy[0] - xy[1])
    last = (xy[-1] - xy[-2]) / np.linalg.norm(xy[-1] - xy[-2])
    probes = np.array([xy[0] + probe * (first + normal), xy[-1] + probe * (last + normal)])
    return bool(shapely.contains_xy(section, probes[:, 0], probes[:, 1]).all())


def _mid_height_facades(scene, exterior_only: bool = False):
    """The target's foot and top, its section at mid-height and that section's façades
    (``_facades``; only the exterior rings' with ``exterior_only``), or None where the
    section is empty."""
    ground, top = float(scene.ground_z), float(scene.bounds("target")[1, 2])
    section = _section_union(scene, 0.5 * (ground + top))
    if section is None or section.is_empty:
        return None
    section = section.simplify(0.05)
    runs = [run for ring in _rings(section) if ring[1] or not exterior_only for run in _facades(*ring)]
    return ground, top, section, runs


def _merged(runs: list[tuple[np.ndarray, bool]], gaps: np.ndarray):
    """The façades with a finite gap, those on one line facing one way across gaps within
    ``MERGE_M`` of each other joined into one straight run from the first's start to the
    last's end (the sides of two notches in one wall flown as one lane): (run, gap) pairs."""
    keep = np.flatnonzero(np.isfinite(gaps))
    if not len(keep):
        return []
    normals = np.array([_midpoint(runs[i])[1] for i in keep])
    angle = np.round(np.degrees(np.arctan2(normals[:, 1], normals[:, 0]))).astype(np.int64)
    tangent = np.column_stack([-normals[:, 1], normals[:, 0]])
    points = [runs[i][0] for i in keep]
    offset = np.array([np.mean(pts @ n) for pts, n in zip(points, normals)])
    key = np.column_stack([angle, np.round(offset / MERGE_M), np.round(gaps[keep] / MERGE_M)])
    _, group = np.unique(key, axis=0, return_inverse=True)
    out = []
    for g in range(int(group.max()) + 1):
        members = np.flatnonzero(group.ravel() == g)
        n, t, c = normals[members[0]], tangent[members[0]], offset[members].mean()
        along = np.concatenate([points[m] @ t for m in members])
        line = c * n + np.outer([along.min(), along.max()], t)
        run = (line, runs[keep[members[0]]][1])
        if _midpoint(run)[1] @ n < 0:
            run = (line[::-1], run[1])
        out.append((run, float(gaps[keep[members]].mean())))
    return out


def across_lanes(scene, camera, limits: ViewLimits, standoff: float, nearest: float,
                 forward_overlap: float = FORWARD_OVERLAP) -> Lanes:
    """One lane per façade of the target's mid-height section whose outward view meets another
    wall within ``GAP_SHARES`` standoffs: along the façade over the far wall, ``nearest`` above
    the target's top, looking back at the façade's mid-height.

    Parameters
    ----------
    scene : Scene
        The scene.
    camera : Camera
        The camera.
    limits : ViewLimits
        The viewpoint rules.
    standoff : float
        The standoff, m.
    nearest : float
        The nearest a lane flies to a surface, m.
    forward_overlap : float
        The share of a frame's width consecutive photos share.

    Returns
    -------
    Lanes
        Not yet clipped (``safe_lanes``).
    """
    found = _mid_height_facades(scene)
    if found is None:
        return Lanes.empty()
    ground, top, section, runs = found
    mid_z = 0.5 * (ground + top)
    gaps = facing_gaps(section, runs, GAP_SHARES * standoff)
    out = Lanes.empty()
    z = top + nearest
    for run, gap in _merged(runs, gaps):
        across = gap + ACROSS_REACH * nearest
        slant = float(np.hypot(across, z - mid_z))
        width = camera.footprint(slant)[0]
        xy, normal = _run_photos(run, width * (1.0 - forward_overlap), OVERRUN * width, across)
        if not len(xy):
            continue
        down = (z - mid_z) / slant
        look = np.column_stack([-normal * (across / slant), np.full(len(xy), -down)])
        pos = np.column_stack([xy, np.full(len(xy), z)])
        out = out.concat(Lanes.runs(Candidates.looking(pos, look, limits, source=LANE_SOURCE),
                                    np.zeros(len(pos), dtype=np.int64)))
    return out


def recess_lanes(scene, camera, limits: ViewLimits, nearest: float, forward_overlap: float = FORWARD_OVERLAP,
                 side_overlap: float = SIDE_OVERLAP) -> Lanes:
    """One straight level lane per recessed façade (the back wall of a notch): a façade whose
    outward view leaves the section's convex hull ``depth`` beyond it, at least ``nearest``,
    without meeting a wall, and whose ends both meet walls turning outward (``_flanked``).
    A wall flanked at one end only (an L's inner corner) is flown round by the rings' wraps.
    The lane runs along it ``depth`` + ``nearest`` out, across the
    recess's mouth, where the wrapped rings only pivot, band above band.

    Parameters
    ----------
    scene : Scene
        The scene.
    camera : Camera
        The camera.
    limits : ViewLimits
        The viewpoint rules.
    nearest : float
        The nearest a lane flies to a surface, m.
    forward_overlap, side_overlap : float
        Shares of the frame consecutive photos and neighbouring bands overlap.

    Returns
    -------
    Lanes
        Not yet clipped (``safe_lanes``).
    """
    found = _mid_height_facades(scene, exterior_only=True)
    if found is None or not found[3]:
        return Lanes.empty()
    ground, top, section, runs = found
    hull = section.convex_hull
    reach = float(np.ptp(np.asarray(hull.exterior.coords), axis=0).max())
    walls = facing_gaps(section, runs, reach)
    depth = facing_gaps(hull, runs, reach)
    out = Lanes.empty()
    for run, d, wall in zip(runs, depth, walls):
        distance = d + nearest
        if not np.isfinite(d) or d < nearest or distance >= wall or not _flanked(section, run):
            continue
        width, height = camera.footprint(distance)
        step, band = lane_steps(camera, distance, forward_overlap, side_overlap)
        xy, normal = _run_photos(run, step, OVERRUN * width, distance)
        for z in band_heights(ground, top, height, band, limits.min_z):
            pos = np.column_stack([xy, np.full(len(xy), z)])
            look = np.column_stack([-normal, np.zeros(len(xy))])
            out = out.concat(Lanes.runs(Candidates.looking(pos, look, limits, source=LANE_SOURCE),
                                        np.zeros(len(pos), dtype=np.int64)))
    return out
