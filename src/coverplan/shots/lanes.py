"""Lanes: runs of photos flown one after the other, each a step of the frame from the last.

A lane's consecutive photos overlap by construction (``forward_overlap`` of the frame along
the run), so a lane is matchable and linked in itself; along a wall it keeps one heading and
one gimbal pitch. Two kinds cover a building:

- façade lanes: on horizontal sections of the target, at band heights spaced by the frame's
  height times (1 - ``side_overlap``), level, at a distance out from the walls. Wrapped (the
  default): the section offset with round corners, square-on along each wall and facing the
  corner on the arc, so the heading turns round a convex corner in steps no wider than a
  step along a wall (about 25 deg at the standoff: photos SfM matches), cut into lanes where
  the offset turns sharply (concave corners). Straight: one lane per façade (the outline cut
  where it turns by more than ``FACADE_TURN_DEG``), past its ends by ``OVERRUN`` of the frame;
  these need edge views to link one wall to the next;
- roof lanes: a nadir grid over the target's upward-facing surface, lanes along the longer
  side of its footprint, the camera's heading along the lane, each photo at the standoff
  above the highest surface within half a frame of it.

Lanes are clipped as candidates are (altitude, ceiling, zones, clearance: ``keep_safe``); a
lane cut by the clipping becomes two lanes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from scipy.spatial import cKDTree

from coverplan.shots.candidates import Candidates, _rings, _section_union, _walk, keep_safe
from coverplan.shots.reachability import ViewLimits

FORWARD_OVERLAP = 0.6  # consecutive photos of a lane share this much of the frame along the run
SIDE_OVERLAP = 0.4  # and neighbouring lanes (bands, roof strips) this much across it
FACADE_TURN_DEG = 30.0  # an outline turning more than this at a vertex starts a new façade
CUT_TURN_DEG = 45.0  # a wrapped lane is cut where its heading turns more than this between two photos
OVERRUN = 0.25  # a façade lane runs past each end of its façade by this share of the frame width
LANE_SOURCE = 5  # Candidates.source of lane photos
NEAR_WALL = 0.7  # a lane photo keeps this share of its distance from every surface (concave corners)
NEAR_LANE_SHARE = 0.5  # façade lanes are also offered at this share of the standoff
ROOF_NORMAL_Z = 0.3  # samples facing up at least this much are roof for the roof lanes


@dataclass(frozen=True)
class Lanes:
    """Lane photos and the lane each belongs to, in flight order within each lane.

    Attributes
    ----------
    cands : Candidates
        The photos, ``source`` ``LANE_SOURCE``; a lane's photos are consecutive rows.
    lane : (n,) int
        The lane of each photo, 0 .. ``count`` - 1.
    """

    cands: Candidates
    lane: np.ndarray

    @property
    def count(self) -> int:
        return int(self.lane.max()) + 1 if len(self.lane) else 0

    def __len__(self) -> int:
        return len(self.cands)

    @classmethod
    def empty(cls) -> "Lanes":
        return cls(Candidates.empty(), np.zeros(0, dtype=np.int64))

    def concat(self, other: "Lanes") -> "Lanes":
        return Lanes(self.cands.concat(other.cands), np.concatenate([self.lane, other.lane + self.count]))

    def subset(self, keep: np.ndarray) -> "Lanes":
        """The photos ``keep`` (bool, (n,)), a lane split where a photo was dropped."""
        keep = np.asarray(keep, dtype=bool)
        if not keep.any():
            return Lanes.empty()
        rows = np.flatnonzero(keep)
        # A new lane starts at a lane's first kept photo or after a dropped one.
        starts = np.r_[True, (np.diff(rows) != 1) | (np.diff(self.lane[rows]) != 0)]
        return Lanes(self.cands.subset(rows), np.cumsum(starts) - 1)

    def neighbours(self) -> np.ndarray:
        """(k, 2) int: rows of consecutive photos of one lane."""
        same = np.flatnonzero(self.lane[1:] == self.lane[:-1])
        return np.column_stack([same, same + 1])


def lane_steps(camera, distance: float, forward_overlap: float = FORWARD_OVERLAP,
               side_overlap: float = SIDE_OVERLAP) -> tuple[float, float]:
    """Photo spacing along a façade lane and band spacing across, m, at ``distance``."""
    width, height = camera.footprint(distance)
    return width * (1.0 - forward_overlap), height * (1.0 - side_overlap)


BAND_MARGIN = 0.1  # the lowest and highest bands' frames reach past the wall's foot and top by this share


def band_heights(ground_z: float, top: float, frame_height: float, band: float, min_z: float) -> np.ndarray:
    """Heights of the façade bands: as few as cover the walls from their foot to ``top`` with
    ``BAND_MARGIN`` of the frame to spare at either end, no further apart than ``band``,
    evenly spread, none below ``min_z``."""
    margin = BAND_MARGIN * frame_height
    lo, hi = ground_z + 0.5 * frame_height - margin, top - 0.5 * frame_height + margin
    if hi <= lo:
        z = np.array([0.5 * (ground_z + top)])
    else:
        z = np.linspace(lo, hi, 1 + int(np.ceil((hi - lo) / band)))
    return np.unique(np.maximum(z, min_z))


def facade_lanes(scene, camera, limits: ViewLimits, distance: float, forward_overlap: float = FORWARD_OVERLAP,
                 side_overlap: float = SIDE_OVERLAP, pitch_deg: float = 0.0, wrap: bool = True,
                 heights: np.ndarray | None = None) -> Lanes:
    """Lanes along every façade of the target's sections, band above band, square-on to the
    façade and pitched ``pitch_deg`` (negative: down).

    Parameters
    ----------
    scene : Scene
    camera : Camera
    limits : ViewLimits
    distance : float
        The standoff, m: how far out from the wall the lanes run.
    forward_overlap, side_overlap : float
        Shares of the frame consecutive photos and neighbouring bands overlap, in [0, 1).
    pitch_deg : float
        The gimbal pitch; a band looks at its height on the wall from ``distance`` away, so a
        pitched lane flies higher and nearer the wall's line than a level one.
    wrap : bool
        Wrap the lanes round the convex corners (the section offset with round corners, its
        photos facing the corner on the arc, no further apart than along a wall): one lane
        from concave corner to concave corner, or round the whole ring. False: one straight
        lane per façade, past its ends by ``OVERRUN`` of the frame.

    Returns
    -------
    Lanes
    """
    width, height = camera.footprint(distance)
    step, band = lane_steps(camera, distance, forward_overlap, side_overlap)
    top = float(scene.bounds("target")[1, 2])
    if heights is None:
        heights = band_heights(scene.ground_z, top, height, band, limits.min_z)
    tilt = np.radians(-pitch_deg)  # down from level
    clearance = scene.clearance_model(limits.security)
    positions, normals, lane = [], [], []
    count = 0
    for z in heights:
        section = _section_union(scene, min(z, top - 1e-3))
        if section is None or section.is_empty:
            continue
        section = section.simplify(0.05)
        out = distance * np.cos(tilt)
        if wrap:
            runs = [run for ring in _rings(section.buffer(out, quad_segs=16))
                    for run in _split_at_turns(*_facing(section, _walk(ring, step)[0]))]
        else:
            runs = [_run_photos(run, step, OVERRUN * width, out)
                    for ring, exterior in _rings(section) for run in _facades(ring, exterior)]
        for pts, nrm in runs:
            if not len(pts):
                continue
            pos = np.column_stack([pts, np.full(len(pts), z + distance * np.sin(tilt))])
            # Past a concave corner the run comes closer to the next wall than its distance.
            ok = clearance.points_clear(pos, NEAR_WALL * distance)
            for piece in _pieces(ok):
                positions.append(pos[piece])
                normals.append(nrm[piece])
                lane.append(np.full(len(piece), count))
                count += 1
    if not positions:
        return Lanes.empty()
    look = -np.vstack(normals) * np.cos(tilt)
    cands = Candidates.looking(np.vstack(positions), np.column_stack([look, np.full(len(look), -np.sin(tilt))]),
                               limits, source=LANE_SOURCE)
    return Lanes(cands, np.concatenate(lane))


def roof_lanes(scene, samples, camera, limits: ViewLimits, distance: float, forward_overlap: float = FORWARD_OVERLAP,
               side_overlap: float = SIDE_OVERLAP) -> Lanes:
    """A nadir grid over the samples facing up, each photo ``distance`` above the highest
    sample within half a frame of it; lanes along the longer side of the roofs' footprint.

    Parameters
    ----------
    samples : SurfaceSamples
        The planner's samples; those whose normal has z >= ``ROOF_NORMAL_Z`` are roof.

    Returns
    -------
    Lanes
    """
    roof = samples.normals[:, 2] >= ROOF_NORMAL_Z
    if roof.sum() < 3:
        return Lanes.empty()
    pts = samples.points[roof]
    width, height = camera.footprint(distance)
    # Heading along the lane: the frame's width sweeps across the lanes, its height along them.
    across, along = width * (1.0 - side_overlap), height * (1.0 - forward_overlap)
    rect = shapely.minimum_rotated_rectangle(shapely.multipoints(pts[:, :2]))
    corners = shapely.get_coordinates(rect)[:4]
    if len(corners) < 4:
        return Lanes.empty()
    edges = np.diff(np.vstack([corners, corners[:1]]), axis=0)
    axis = edges[int(np.argmax(np.linalg.norm(edges, axis=1)))]
    axis = axis / max(np.linalg.norm(axis), 1e-12)
    side = np.array([-axis[1], axis[0]])
    centre = pts[:, :2].mean(axis=0)
    u, v = (pts[:, :2] - centre) @ axis, (pts[:, :2] - centre) @ side
    margin = 0.25 * min(width, height)
    rows = _spaced(v.min() - margin, v.max() + margin, across)
    cols = _spaced(u.min() - margin, u.max() + margin, along)
    uu, vv = np.meshgrid(cols, rows)
    uu[1::2] = uu[1::2, ::-1]  # a lawnmower: every other lane flown back
    xy = centre + uu.reshape(-1, 1) * axis + vv.reshape(-1, 1) * side
    lane = np.repeat(np.arange(len(rows)), len(cols))
    reach = 0.5 * min(width, height)
    over = cKDTree(pts[:, :2]).query_ball_point(xy, reach, return_length=True) > 0
    z = _highest_within(samples.points, xy, reach) + distance
    keep = over & np.isfinite(z)
    heading = np.degrees(np.arctan2(axis[0], axis[1])) % 360.0
    cands = Candidates(np.column_stack([xy, z]), np.full(len(xy), heading), np.full(len(xy), -90.0),
                       np.full(len(xy), LANE_SOURCE, dtype=np.int8))
    cands.pitch_deg = np.clip(cands.pitch_deg, *limits.pitch_range_deg)
    return Lanes(cands, lane).subset(keep)


def safe_lanes(scene, lanes: Lanes, limits: ViewLimits, margin: float) -> Lanes:
    """``keep_safe`` on lane photos: a lane is cut where a photo is not safe."""
    if len(lanes) == 0:
        return lanes
    tagged = Candidates(lanes.cands.positions, lanes.cands.heading_deg, lanes.cands.pitch_deg,
                        np.arange(len(lanes)).astype(np.int64))
    kept = keep_safe(scene, tagged, limits, margin).source
    mask = np.zeros(len(lanes), dtype=bool)
    mask[kept] = True
    return lanes.subset(mask)


def _highest_within(points: np.ndarray, xy: np.ndarray, radius: float) -> np.ndarray:
    """(m,) the highest z of ``points`` (n, 3) within ``radius`` of each ``xy`` (m, 2)
    horizontally; -inf where none is."""
    near = cKDTree(points[:, :2]).query_ball_point(xy, radius)
    sizes = np.array([len(n) for n in near])
    out = np.full(len(xy), -np.inf)
    if sizes.sum() == 0:
        return out
    flat = np.concatenate([np.asarray(n, dtype=np.int64) for n in near if len(n)])
    starts = np.r_[0, np.cumsum(sizes[sizes > 0])[:-1]]
    out[sizes > 0] = np.maximum.reduceat(points[flat, 2], starts)
    return out


def _spaced(lo: float, hi: float, step: float) -> np.ndarray:
    """Evenly spaced points from ``lo`` to ``hi``, no further apart than ``step``."""
    n = max(int(np.ceil((hi - lo) / step)), 0) + 1
    return np.linspace(lo, hi, n) if n > 1 else np.array([0.5 * (lo + hi)])


def _facades(coords: np.ndarray, exterior: bool) -> list[tuple[np.ndarray, bool]]:
    """A closed ring split into façades at the vertices where it turns by more than
    ``FACADE_TURN_DEG``: (polyline (m, 2), exterior) per façade; a ring that never turns
    that much is one façade, closed."""
    ring = shapely.LinearRing(coords)
    pts = np.asarray(ring.coords)[:-1]
    if not ring.is_ccw:  # every ring counter-clockwise (_run_photos finds outward from it)
        pts = pts[::-1]
    if len(pts) < 3:
        return []
    d_in = pts - np.roll(pts, 1, axis=0)
    d_out = np.roll(pts, -1, axis=0) - pts
    turn = np.degrees(np.abs(np.arctan2(d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0],
                                        np.einsum("ij,ij->i", d_in, d_out))))
    corners = np.flatnonzero(turn > FACADE_TURN_DEG)
    if len(corners) == 0:
        return [(np.vstack([pts, pts[:1]]), exterior)]
    out = []
    for a, b in zip(corners, np.roll(corners, -1)):
        idx = np.arange(a, b + 1) if b > a else np.r_[np.arange(a, len(pts)), np.arange(0, b + 1)]
        out.append((pts[idx], exterior))
    return out


def _run_photos(run: tuple[np.ndarray, bool], step: float, overrun: float, distance: float):
    """Photo positions (k, 2) along a façade at ``distance`` out from it, every ``step`` at
    most, from ``overrun`` before its start to ``overrun`` past its end, and the façade's
    outward normal (k, 2) at each."""
    line, exterior = run
    seg = np.diff(line, axis=0)
    length = np.linalg.norm(seg, axis=1)
    keep = length > 1e-9
    seg, length, starts = seg[keep], length[keep], line[:-1][keep]
    if not len(seg):
        return np.zeros((0, 2)), np.zeros((0, 2))
    tangent = seg / length[:, None]
    # The ring runs counter-clockwise: outward is right of the direction of travel for the
    # exterior, left for a hole (whose inside is the open courtyard).
    normal = np.column_stack([tangent[:, 1], -tangent[:, 0]])
    if not exterior:
        normal = -normal
    total = float(length.sum())
    s = _spaced(-overrun, total + overrun, step)
    edge = np.clip(np.searchsorted(np.cumsum(length), s, side="right"), 0, len(seg) - 1)
    offset = s - np.r_[0.0, np.cumsum(length)[:-1]][edge]
    base = starts[edge] + tangent[edge] * offset[:, None]
    return base + normal[edge] * distance, normal[edge]


def _facing(section, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``pts`` (k, 2) and the unit vectors (k, 2) from the nearest point of ``section`` to each:
    square-on to a wall beside it, towards the corner round which it turns."""
    if not len(pts):
        return pts, np.zeros((0, 2))
    near = shapely.get_coordinates(shapely.shortest_line(shapely.points(pts), section))[1::2]
    away = pts - near
    return pts, away / np.maximum(np.linalg.norm(away, axis=1, keepdims=True), 1e-12)


def _split_at_turns(pts: np.ndarray, normals: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """A closed ring's photos (k, 2) and outward normals (k, 2) cut where the normal turns by
    more than ``CUT_TURN_DEG`` from one photo to the next (the offset's concave corners):
    runs in walking order, or the whole ring when it never turns that much."""
    if len(pts) == 0:
        return []
    turn = np.einsum("ij,ij->i", normals, np.roll(normals, -1, axis=0)) < np.cos(np.radians(CUT_TURN_DEG))
    cuts = np.flatnonzero(turn)
    if not len(cuts):
        return [(pts, normals)]
    order = np.roll(np.arange(len(pts)), -(cuts[0] + 1))  # start just after a cut
    pieces = np.split(order, np.flatnonzero(np.isin(order, cuts[1:])) + 1)
    return [(pts[p], normals[p]) for p in pieces if len(p)]


def _pieces(ok: np.ndarray) -> list[np.ndarray]:
    """Runs of consecutive True in ``ok`` as index arrays."""
    idx = np.flatnonzero(ok)
    if not len(idx):
        return []
    return np.split(idx, np.flatnonzero(np.diff(idx) != 1) + 1)
