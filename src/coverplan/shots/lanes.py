"""Lanes: runs of photos flown one after the other, each a step of the frame from the last.

A lane's consecutive photos overlap by construction (``forward_overlap`` of the frame along
the run), so a lane is matchable and linked in itself; along a wall it keeps one heading and
one gimbal pitch. Three kinds cover a building:

- façade lanes: on horizontal sections of the target, at band heights spaced by the frame's
  height times (1 - ``side_overlap``), level, at a distance out from the walls. Wrapped (the
  default): one closed lane per ring of the section offset with round corners, square-on
  along each wall; round half its corners the heading turns in smooth steps (at most
  ``LANE_TURN_DEG``), round the others in two steps with a photo on the corner's bisector
  (``smooth_walk``), and at the offset's concave corners the photos pivot in place. A ring is
  offered in pieces, a wall or a run of walls between corners, so that the cover can take
  part of it (``ring_lane``). Straight: one lane per façade, past its ends by ``OVERRUN`` of
  the frame;
- courtyard lanes: round the inside of a courtyard too narrow for the standoff, close to its
  walls, looking across at the far ones (``courtyard_lanes``);
- roof lanes: a nadir grid over the target's upward-facing surface, strips along the longer
  side of its footprint flown as a lawnmower, one heading throughout, each photo at the
  standoff above the highest surface within half a frame of it; each strip a piece.

Lanes are clipped as candidates are (altitude, ceiling, zones, clearance: ``keep_safe``); a
lane cut by the clipping becomes two lanes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from coverplan.shots.candidates import Candidates, _rings, _section_union, keep_safe
from coverplan.shots.lane_rings import SMOOTH_SHARE, ring_lane, smooth_walk
from coverplan.shots.limits import ViewLimits

FORWARD_OVERLAP = 0.6  # consecutive photos of a lane share this much of the frame along the run
SIDE_OVERLAP = 0.4  # and neighbouring lanes (bands, roof strips) this much across it
FACADE_TURN_DEG = 30.0  # an outline turning more than this at a vertex starts a new façade
OVERRUN = 0.25  # a façade lane runs past each end of its façade by this share of the frame width
LANE_SOURCE = 5  # Candidates.source of lane photos
NEAR_WALL = 0.7  # a lane photo keeps this share of its distance from every surface (concave corners)
NEAR_LANE_SHARES = (0.7,)  # façade lanes are also offered at these shares of the standoff


@dataclass(frozen=True)
class Lanes:
    """Lane photos, the lane each belongs to, in flight order within each lane, and the pieces
    of lanes the cover chooses from.

    Parameters
    ----------
    cands : Candidates
        The photos, ``source`` ``LANE_SOURCE``; a lane's photos are consecutive rows.
    lane : (n,) int
        The lane of each photo, 0 .. ``count`` - 1.
    pieces : (p, 3) int
        Per piece: its lane, first row and the row after its last. The pieces of a lane cover
        it; neighbouring pieces share their end row. A lane chosen piece by piece is one run
        where the chosen pieces touch.
    closed : (count,) bool
        Lanes round a ring: the last row is the first photo again (so that every piece is a run
        of rows); chosen whole, the ring is flown once round without it.
    """

    cands: Candidates
    lane: np.ndarray
    pieces: np.ndarray
    closed: np.ndarray

    @property
    def count(self) -> int:
        """How many lanes."""
        return int(self.lane.max()) + 1 if len(self.lane) else 0

    def __len__(self) -> int:
        return len(self.cands)

    @classmethod
    def empty(cls) -> Lanes:
        """No lanes.

        Returns
        -------
        Lanes
            Zero photos.
        """
        return cls(Candidates.empty(), np.zeros(0, dtype=np.int64), np.zeros((0, 3), dtype=np.int64),
                   np.zeros(0, dtype=bool))

    @classmethod
    def runs(cls, cands: Candidates, lane: np.ndarray) -> Lanes:
        """Lanes of one piece each, not closed.

        Parameters
        ----------
        cands : Candidates
            The photos, each lane's consecutive.
        lane : (n,) int
            The lane of each photo.

        Returns
        -------
        Lanes
            The lanes.
        """
        lane = np.asarray(lane, dtype=np.int64)
        n = int(lane.max()) + 1 if len(lane) else 0
        first = np.searchsorted(lane, np.arange(n))
        return cls(cands, lane, np.column_stack([np.arange(n), first, np.r_[first[1:], len(lane)]]).astype(np.int64),
                   np.zeros(n, dtype=bool))

    def concat(self, other: Lanes) -> Lanes:
        """These lanes followed by ``other``'s, renumbered after them.

        Parameters
        ----------
        other : Lanes
            More lanes.

        Returns
        -------
        Lanes
            A new set.
        """
        shift = np.array([self.count, len(self), len(self)])
        return Lanes(self.cands.concat(other.cands), np.concatenate([self.lane, other.lane + self.count]),
                     np.vstack([self.pieces, other.pieces + shift]), np.concatenate([self.closed, other.closed]))

    def subset(self, keep: np.ndarray) -> Lanes:
        """The photos ``keep`` (bool, (n,)): a lane, and each of its pieces, split where a photo
        was dropped; a ring that loses a photo is no longer closed.

        Parameters
        ----------
        keep : (n,) bool
            Photos to keep.

        Returns
        -------
        Lanes
            A new set, or this one when every photo is kept.
        """
        keep = np.asarray(keep, dtype=bool)
        if not keep.any():
            return Lanes.empty()
        if keep.all():
            return self
        rows = np.flatnonzero(keep)
        # A new lane starts at a lane's first kept photo or after a dropped one.
        starts = np.r_[True, (np.diff(rows) != 1) | (np.diff(self.lane[rows]) != 0)]
        lane = np.cumsum(starts) - 1
        new_row = np.cumsum(keep) - 1
        pieces = []
        for _, first, stop in self.pieces:
            kept = first + np.flatnonzero(keep[first:stop])
            for run in _pieces(np.isin(np.arange(first, stop), kept)):
                r = new_row[first + run]
                pieces.append((lane[r[0]], r[0], r[-1] + 1))
        whole = np.bincount(self.lane[rows], minlength=self.count) == np.bincount(self.lane, minlength=self.count)
        closed = np.zeros(int(lane.max()) + 1, dtype=bool)
        closed[lane[starts]] = (self.closed & whole)[self.lane[rows[starts]]]
        return Lanes(self.cands.subset(rows), lane, np.array(pieces, dtype=np.int64).reshape(-1, 3), closed)

    def neighbours(self) -> np.ndarray:
        """(k, 2) int: rows of consecutive photos of one lane.

        Returns
        -------
        (k, 2) int
            Row pairs.
        """
        same = np.flatnonzero(self.lane[1:] == self.lane[:-1])
        return np.column_stack([same, same + 1])


def lane_steps(camera, distance: float, forward_overlap: float = FORWARD_OVERLAP,
               side_overlap: float = SIDE_OVERLAP) -> tuple[float, float]:
    """Photo spacing along a façade lane and band spacing across, m, at ``distance``.

    Parameters
    ----------
    camera : Camera
        The camera.
    distance : float
        Metres.
    forward_overlap : float
        The share of a frame's width consecutive photos share.
    side_overlap : float
        The share of its height neighbouring bands share.

    Returns
    -------
    step, band : float
        Metres.
    """
    width, height = camera.footprint(distance)
    return width * (1.0 - forward_overlap), height * (1.0 - side_overlap)


BAND_MARGIN = 0.1  # the lowest and highest bands' frames reach past the wall's foot and top by this share


def band_heights(ground_z: float, top: float, frame_height: float, band: float, min_z: float) -> np.ndarray:
    """Heights of the façade bands: as few as cover the walls from their foot to ``top`` with
    ``BAND_MARGIN`` of the frame to spare at either end, no further apart than ``band``,
    evenly spread, none below ``min_z``; one band at mid-height where one frame spans the wall
    with half that margin to spare.

    Parameters
    ----------
    ground_z : float
        The walls' foot, metres.
    top : float
        Their top, metres.
    frame_height : float
        The frame's height on the wall, metres.
    band : float
        The largest spacing, metres.
    min_z : float
        The lowest height allowed, metres.

    Returns
    -------
    (k,) float
        Heights, metres.
    """
    margin = BAND_MARGIN * frame_height
    lo, hi = ground_z + 0.5 * frame_height - margin, top - 0.5 * frame_height + margin
    if top - ground_z <= frame_height - margin:  # one frame spans the wall with half the margin to spare
        z = np.array([0.5 * (ground_z + top)])
    else:
        z = np.linspace(lo, hi, 1 + int(np.ceil((hi - lo) / band)))
    return np.unique(np.maximum(z, min_z))


def facade_lanes(scene, camera, limits: ViewLimits, distance: float, forward_overlap: float = FORWARD_OVERLAP,
                 side_overlap: float = SIDE_OVERLAP, pitch_deg: float = 0.0, wrap: bool = True,
                 heights: np.ndarray | None = None, smooth_share: float = SMOOTH_SHARE) -> Lanes:
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
        Wrap the lanes round the building: one closed lane per ring of the section offset with
        round corners (``smooth_walk``), its photos facing the nearest wall, in pieces cut at
        the corners (``ring_lane``). False: one straight lane per façade, past its ends by
        ``OVERRUN`` of the frame.
    heights : (k,) float, optional
        The bands' heights; by default ``band_heights``.
    smooth_share : float
        Under ``wrap``: the share of each ring's corners turned in smooth steps.

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
    out = Lanes.empty()
    for z in heights:
        section = _section_union(scene, min(z, top - 1e-3))
        if section is None or section.is_empty:
            continue
        section = section.simplify(0.05)
        reach = distance * np.cos(tilt)
        if wrap:
            rings = [ring_lane(*smooth_walk(ring, section, step, smooth_share))
                     for ring in _rings(section.buffer(reach, quad_segs=16))]
        else:
            rings = [(xy, nrm, np.array([[0, 0, len(xy)]]), False) for ring, exterior in _rings(section)
                     for xy, nrm in [_run_photos(run, step, OVERRUN * width, reach) for run in _facades(ring, exterior)]]
        for xy, nrm, pieces, closed in rings:
            if not len(xy):
                continue
            pos = np.column_stack([xy, np.full(len(xy), z + distance * np.sin(tilt))])
            look = np.column_stack([-nrm * np.cos(tilt), np.full(len(nrm), -np.sin(tilt))])
            one = Lanes(Candidates.looking(pos, look, limits, source=LANE_SOURCE), np.zeros(len(pos), dtype=np.int64),
                        np.asarray(pieces, dtype=np.int64), np.array([closed]))
            # Past a concave corner the run comes closer to the next wall than its distance.
            out = out.concat(one.subset(clearance.points_clear(pos, NEAR_WALL * distance)))
    return out


def courtyard_lanes(scene, camera, limits: ViewLimits, offset: float, distance: float,
                    forward_overlap: float = FORWARD_OVERLAP, side_overlap: float = SIDE_OVERLAP,
                    smooth_share: float = SMOOTH_SHARE) -> Lanes:
    """Lanes round the inside of every courtyard (a hole of the target's sections), ``offset``
    from its walls, looking across it at the far walls: a courtyard too narrow for a lane at
    the standoff is photographed from across, at about the standoff.

    Parameters
    ----------
    scene : Scene
        The scene.
    camera : Camera
        The camera.
    limits : ViewLimits
        The viewpoint rules.
    offset : float
        How far from the nearest wall the lanes run, m.
    distance : float
        The standoff, m: the bands are spaced for the frame there.
    forward_overlap : float
        The share of a frame's width consecutive photos share.
    side_overlap : float
        The share of its height neighbouring bands share.
    smooth_share : float
        The share of corners rounded in smooth steps.

    Returns
    -------
    Lanes
    """
    step, band = lane_steps(camera, distance, forward_overlap, side_overlap)
    top = float(scene.bounds("target")[1, 2])
    heights = band_heights(scene.ground_z, top, camera.footprint(distance)[1], band, limits.min_z)
    clearance = scene.clearance_model(limits.security)
    out = Lanes.empty()
    for z in heights:
        section = _section_union(scene, min(z, top - 1e-3))
        if section is None or section.is_empty:
            continue
        section = section.simplify(0.05)
        holes = [shapely.Polygon(h) for g in getattr(section, "geoms", [section]) for h in g.interiors]
        for hole in holes:
            for ring in _rings(hole.buffer(-offset)):
                xy, away, pieces, closed = ring_lane(*smooth_walk(ring, section, step, smooth_share))
                if not len(xy):
                    continue
                pos = np.column_stack([xy, np.full(len(xy), z)])
                one = Lanes(Candidates.looking(pos, np.column_stack([away, np.zeros(len(away))]), limits,
                                               source=LANE_SOURCE),
                            np.zeros(len(pos), dtype=np.int64), pieces, np.array([closed]))
                out = out.concat(one.subset(clearance.points_clear(pos, 0.9 * offset)))
    return out


def safe_lanes(scene, lanes: Lanes, limits: ViewLimits, margin: float) -> Lanes:
    """``keep_safe`` on lane photos: a lane is cut where a photo is not safe.

    Parameters
    ----------
    scene : Scene
        The scene.
    lanes : Lanes
        The lanes.
    limits : ViewLimits
        Security distance and altitude band.
    margin : float
        Metres beyond the security distance.

    Returns
    -------
    Lanes
        The safe pieces.
    """
    if len(lanes) == 0:
        return lanes
    tagged = Candidates(lanes.cands.positions, lanes.cands.heading_deg, lanes.cands.pitch_deg,
                        np.arange(len(lanes)).astype(np.int64))
    kept = keep_safe(scene, tagged, limits, margin).source
    mask = np.zeros(len(lanes), dtype=bool)
    mask[kept] = True
    return lanes.subset(mask)


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


def _pieces(ok: np.ndarray) -> list[np.ndarray]:
    """Runs of consecutive True in ``ok`` as index arrays."""
    idx = np.flatnonzero(ok)
    if not len(idx):
        return []
    return np.split(idx, np.flatnonzero(np.diff(idx) != 1) + 1)
