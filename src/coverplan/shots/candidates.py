"""Candidate viewpoints: where a shot could be taken, and which way it would look.

Five generators, all 3D:

- ``facade_rings``: horizontal sections of the target (trimesh) offset outward by the
  standoff (shapely) and walked along, cameras facing the wall at a few headings;
- ``along_normals``: for a thinned set of samples, positions at the standoff along the
  normal and along directions tilted from it (roofs look down, overhang undersides up);
- ``edge_views`` (edge_views.py): cameras on the bisector of the two faces at each edge where the surface
  turns (a wall's corner, a roof's eave or ridge), seeing both faces alike;
- ``under_overhangs``: for down-facing samples, cameras below and beside them looking up as
  steeply as the gimbal and the frame allow (``along_normals`` puts those under the ground);
- ``from_probes`` (probe_views.py): for samples the others leave short, the reachability probes that work.

Every candidate is then checked: above the minimum altitude, clear of every mesh by the
security distance plus a margin, aimable by the gimbal.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import MultiPolygon, Polygon
from shapely.ops import unary_union

from coverplan.geometry.orientation import heading_pitch, view_direction
from coverplan.shots.limits import ViewLimits
from coverplan.shots.reachability import tangent_frames
from coverplan.shots.surface import OPPOSED_TERRACE


@dataclass
class Candidates:
    """Camera poses: positions (n, 3), headings and pitches (deg), and how each was made.

    Parameters
    ----------
    positions : (n, 3) float
        Camera centres, local frame.
    heading_deg, pitch_deg : (n,) float
        Orientations.
    source : (n,) int8
        How each was made (0 façade rings, 1 along normals, 2 probes, ...).
    """

    positions: np.ndarray
    heading_deg: np.ndarray
    pitch_deg: np.ndarray
    source: np.ndarray  # 0 facade ring, 1 along normal, 2 probe, EDGE (3) edge view, EXISTING a photo already taken

    def __len__(self) -> int:
        return len(self.positions)

    @classmethod
    def empty(cls) -> "Candidates":
        """No candidates.

        Returns
        -------
        Candidates
            Zero rows.
        """
        return cls(np.zeros((0, 3)), np.zeros(0), np.zeros(0), np.zeros(0, np.int8))

    @classmethod
    def looking(cls, positions, view_dirs, limits: ViewLimits, source: int) -> "Candidates":
        """Cameras at ``positions`` looking along ``view_dirs``, pitch clipped to the gimbal.

        Parameters
        ----------
        positions : (n, 3) float
            Camera centres.
        view_dirs : (n, 3) float
            Unit view vectors.
        limits : ViewLimits
            Gives the gimbal range.
        source : int
            How they were made.

        Returns
        -------
        Candidates
            The cameras.
        """
        heading, pitch = heading_pitch(view_dirs)
        pitch = np.clip(pitch, *limits.pitch_range_deg)
        return cls(np.asarray(positions, float).reshape(-1, 3), heading, pitch,
                   np.full(len(heading), source, dtype=np.int8))

    def concat(self, other: "Candidates") -> "Candidates":
        """These candidates followed by ``other``.

        Parameters
        ----------
        other : Candidates
            More candidates.

        Returns
        -------
        Candidates
            A new set.
        """
        return Candidates(np.vstack([self.positions, other.positions]),
                          np.concatenate([self.heading_deg, other.heading_deg]),
                          np.concatenate([self.pitch_deg, other.pitch_deg]),
                          np.concatenate([self.source, other.source]))

    def subset(self, mask) -> "Candidates":
        """The candidates ``mask`` selects.

        Parameters
        ----------
        mask : (n,) bool or (k,) int
            Rows to keep.

        Returns
        -------
        Candidates
            A new set.
        """
        return Candidates(self.positions[mask], self.heading_deg[mask], self.pitch_deg[mask], self.source[mask])

    @property
    def view_dirs(self) -> np.ndarray:
        """(n, 3) float: unit view vectors of the headings and pitches."""
        return view_direction(self.heading_deg, self.pitch_deg)


def standoff(camera, limits: ViewLimits, margin: float) -> float:
    """Distance from the wall for candidates: the whole frame within d_opt on a facing wall,
    but never closer than the security distance plus margin.

    Parameters
    ----------
    camera : Camera
        The camera.
    limits : ViewLimits
        Security distance and d_opt.
    margin : float
        Metres beyond the security distance.

    Returns
    -------
    float
        Metres.
    """
    nearest = limits.security + margin
    ideal = limits.d_opt / camera.corner_factor * 0.97
    return float(min(max(ideal, nearest * 1.05), limits.d_opt * 0.95))


def slice_heights(scene, limits: ViewLimits, camera, distance: float, spacing: float = 0.0) -> np.ndarray:
    """Heights of the façade slices: spaced by half the vertical footprint at ``distance``
    (never closer than the sample spacing: denser than the samples sees nothing new).

    Parameters
    ----------
    scene : Scene
        The scene.
    limits : ViewLimits
        The altitude band.
    camera : Camera
        The camera.
    distance : float
        The camera distance, metres.
    spacing : float
        The sample spacing, metres.

    Returns
    -------
    (k,) float
        Heights, metres.
    """
    top = scene.bounds("target")[1, 2]
    step = max(camera.footprint(distance)[1] * 0.5, spacing)
    start = max(limits.min_z, scene.ground_z + step * 0.5)
    if start > top:
        return np.array([start])
    return np.arange(start, top + step * 0.5, step)


VIEW_TILTS = ("varied", "corners", "square")  # PlanSettings.view_tilts
CORNER_REACH = 2  # ring points either side of a turn that keep their tilted views under "corners"


def facade_rings(scene, camera, limits: ViewLimits, distance: float, spacing: float = 0.0,
                 view_tilts: str = "varied") -> Candidates:
    """Cameras on the target's horizontal sections offset by ``distance``, facing the walls
    square-on and a third of the field of view either side: everywhere (``view_tilts``
    "varied"), only where the ring turns and CORNER_REACH points either side ("corners"), or
    nowhere ("square").

    Parameters
    ----------
    scene : Scene
        The scene.
    camera : Camera
        The camera.
    limits : ViewLimits
        The viewpoint rules.
    distance : float
        The offset from the walls, metres.
    spacing : float
        The sample spacing, metres.
    view_tilts : {"varied", "corners", "square"}
        Where the side-looking views are made.

    Returns
    -------
    Candidates
        The cameras.
    """
    if view_tilts not in VIEW_TILTS:
        raise ValueError(f"view_tilts must be one of {VIEW_TILTS}, got {view_tilts!r}")
    width = camera.footprint(distance)[0]
    step = max(width / 4.0, spacing)
    tilt = min(camera.hfov_deg / 3.0, 30.0)
    tilts = (0.0,) if view_tilts == "square" else (-tilt, 0.0, tilt)
    positions, dirs = [], []
    heights = slice_heights(scene, limits, camera, distance, spacing)
    # A slice above the roof walks the section just under the roof.
    for z in heights:
        section = _section_union(scene, min(z, scene.bounds("target")[1, 2] - 1e-3))
        if section is None or section.is_empty:
            continue
        offset = section.buffer(distance, quad_segs=8)
        for ring in _rings(offset):
            pts, outward = _walk(ring, step)
            if len(pts) == 0:
                continue
            pos3 = np.column_stack([pts, np.full(len(pts), z)])
            every = np.ones(len(pts), dtype=bool)
            turns = _near_turns(outward, CORNER_REACH) if view_tilts == "corners" else every
            for t in tilts:
                a = np.radians(t)
                inward = -outward
                rot = np.column_stack([inward[:, 0] * np.cos(a) - inward[:, 1] * np.sin(a),
                                       inward[:, 0] * np.sin(a) + inward[:, 1] * np.cos(a)])
                at = turns if t else every
                positions.append(pos3[at])
                dirs.append(np.column_stack([rot, np.zeros(len(rot))])[at])
    if not positions:
        return Candidates.empty()
    return Candidates.looking(np.vstack(positions), np.vstack(dirs), limits, source=0)


def along_normals(samples, limits: ViewLimits, camera, distance: float, tilt_deg: float = 30.0,
                  n_tilts: int = 4) -> Candidates:
    """Cameras at ``distance`` along each thinned sample's normal and tilted about it.

    Parameters
    ----------
    samples : SurfaceSamples
        The samples, thinned here.
    limits : ViewLimits
        The viewpoint rules.
    camera : Camera
        The camera.
    distance : float
        Metres.
    tilt_deg : float
        The tilt about the normal.
    n_tilts : int
        Tilted views per sample.

    Returns
    -------
    Candidates
        The cameras.
    """
    cell = max(camera.footprint(distance)[1] * 0.35, samples.spacing)
    picked = thin(samples.points, samples.normals, cell)
    pts, nrm = samples.points[picked], samples.normals[picked]
    t1, t2 = tangent_frames(nrm)
    dirs = [nrm]
    a = np.radians(tilt_deg)
    for k in range(n_tilts):
        phi = 2 * np.pi * k / n_tilts
        dirs.append(np.cos(a) * nrm + np.sin(a) * (np.cos(phi) * t1 + np.sin(phi) * t2))
    out = np.stack(dirs, axis=1)  # (n, 1 + n_tilts, 3): sample -> camera
    positions = (pts[:, None, :] + out * distance).reshape(-1, 3)
    rays = out.reshape(-1, 3)
    ok = limits.elevation_ok(rays)
    return Candidates.looking(positions[ok], -rays[ok], limits, source=1)


def under_overhangs(samples, limits: ViewLimits, camera, margin: float, n_azimuths: int = 8) -> Candidates:
    """Cameras that see down-facing samples at the smallest incidence the gimbal allows.

    The ray from the sample climbs down at the steepest elevation a camera tilted to the
    gimbal's top pitch still frames (90 % of the way to the frame's edge), in ``n_azimuths``
    directions, to the floor or d_opt, and halfway there. With the gimbal's +30 deg that is
    an incidence of about 37 deg; ``along_normals`` and the probes left the edge strip of an
    overhang at 43-45 deg (ring prism).

    Parameters
    ----------
    samples : SurfaceSamples
        The samples.
    limits : ViewLimits
        The viewpoint rules.
    camera : Camera
        The camera.
    margin : float
        Metres beyond the security distance.
    n_azimuths : int
        Directions per sample.

    Returns
    -------
    Candidates
        The cameras.
    """
    down = np.flatnonzero(samples.kind == OPPOSED_TERRACE)
    if len(down) == 0:
        return Candidates.empty()
    # One seed per cell of a third of the frame at 0.7 d_opt: half that cell gave 2,800
    # candidates under the ring prism's overhang and made the LP 5x slower for 3 % of the
    # underside seen within 40 deg.
    cell = max(camera.footprint(0.7 * limits.d_opt)[1] * 0.35, samples.spacing)
    picked = down[thin(samples.points[down], samples.normals[down], cell)]
    pts, nrm = samples.points[picked], samples.normals[picked]
    elevation = np.radians(min(limits.pitch_range_deg[1] + 0.45 * limits.vfov_deg, 89.0))
    az = 2 * np.pi * np.arange(n_azimuths) / n_azimuths
    dirs = np.column_stack([np.cos(elevation) * np.sin(az), np.cos(elevation) * np.cos(az),
                            np.full(n_azimuths, -np.sin(elevation))])  # sample -> camera
    nearest = limits.security + margin
    to_floor = (pts[:, 2] - limits.floor_at(pts[:, :2])) * 0.98 / np.sin(elevation)
    far = np.minimum(to_floor, 0.95 * limits.d_opt)
    ranges = np.stack([far, 0.5 * (far + nearest)], axis=1)  # (n, 2)
    positions = pts[:, None, None, :] + dirs[None, :, None, :] * ranges[:, None, :, None]
    rays = np.broadcast_to(dirs[None, :, None, :], positions.shape)
    facing = np.einsum("nk,nadk->nad", nrm, rays) >= np.cos(np.radians(limits.max_incidence_deg))
    ok = facing & (ranges[:, None, :] >= nearest)
    return Candidates.looking(positions[ok], -rays[ok], limits, source=1)


def keep_safe(scene, candidates: Candidates, limits: ViewLimits, margin: float) -> Candidates:
    """Drop candidates below the minimum altitude or closer than security + margin to a mesh.

    Parameters
    ----------
    scene : Scene
        The scene.
    candidates : Candidates
        The cameras.
    limits : ViewLimits
        Security distance and altitude band.
    margin : float
        Metres beyond the security distance.

    Returns
    -------
    Candidates
        The safe ones.
    """
    if len(candidates) == 0:
        return candidates
    ok = limits.allowed(candidates.positions, tol=0.0)
    idx = np.flatnonzero(ok)
    clearance = scene.clearance_model(limits.security)
    ok[idx] = clearance.points_clear(candidates.positions[idx], limits.security + margin)
    return candidates.subset(ok)


# -- helpers --------------------------------------------------------------------------------

def _section_union(scene, z: float):
    polys = []
    for part in scene.targets:
        lo, hi = part.mesh.bounds[:, 2]
        if not (lo < z < hi):
            continue
        section = part.mesh.section(plane_origin=[0, 0, z], plane_normal=[0, 0, 1])
        if section is None:
            continue
        try:
            planar, _ = section.to_2D(to_2D=np.eye(4))
            polys.extend(planar.polygons_full)
        except Exception:  # open or self-touching sections: fall back to hulls of the paths
            for path in section.discrete:
                if len(path) >= 3:
                    polys.append(Polygon(path[:, :2]).convex_hull)
    if not polys:
        return None
    return unary_union([shapely.make_valid(p) for p in polys])


def _rings(geometry):
    geoms = geometry.geoms if isinstance(geometry, MultiPolygon) else [geometry]
    for poly in geoms:
        if isinstance(poly, Polygon) and not poly.is_empty:
            yield np.asarray(poly.exterior.coords), True
            for hole in poly.interiors:
                yield np.asarray(hole.coords), False


def _walk(ring_and_kind, step: float):
    """Points every ``step`` along a closed ring and the outward (away from the target) normals."""
    coords, exterior = ring_and_kind
    ring = shapely.LinearRing(coords)
    length = ring.length
    if length < 1e-9:
        return np.zeros((0, 2)), np.zeros((0, 2))
    n = max(int(np.ceil(length / step)), 3)
    s = np.arange(n) * length / n
    pts = shapely.get_coordinates(shapely.line_interpolate_point(ring, s))
    ahead = shapely.get_coordinates(shapely.line_interpolate_point(ring, (s + 1e-3 * step) % length))
    behind = shapely.get_coordinates(shapely.line_interpolate_point(ring, (s - 1e-3 * step) % length))
    tangent = ahead - behind
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-12)
    normal = np.column_stack([tangent[:, 1], -tangent[:, 0]])  # right of the direction of travel
    # Exteriors should be counter-clockwise and holes clockwise, so "right" points away from the
    # polygon in both; shapely does not promise the orientation, so check it.
    if ring.is_ccw != exterior:
        normal = -normal
    return pts, normal


def _near_turns(outward, reach: int, min_turn_deg: float = 2.0) -> np.ndarray:
    """(n,) bool: points of a closed ring whose outward normal turns by more than
    ``min_turn_deg`` to a neighbour's, and ``reach`` points either side of them."""
    turn = np.einsum("ij,ij->i", outward, np.roll(outward, -1, axis=0)) < np.cos(np.radians(min_turn_deg))
    turning = turn | np.roll(turn, 1)  # both ends of a turning step
    near = turning.copy()
    for k in range(1, reach + 1):
        near |= np.roll(turning, k) | np.roll(turning, -k)
    return near


def thin(points, normals, cell: float) -> np.ndarray:
    """Indices of one sample per (cell, normal octant): the one nearest the cell's centre.

    Parameters
    ----------
    points : (n, 3) float
        Samples.
    normals : (n, 3) float
        Their normals.
    cell : float
        Metres.

    Returns
    -------
    (k,) int
        Indices into ``points``.
    """
    key = np.column_stack([np.floor(points / cell).astype(np.int64), (normals > 0.3).astype(np.int64),
                           (normals < -0.3).astype(np.int64)])
    _, group = np.unique(key, axis=0, return_inverse=True)
    group = group.ravel()
    centre = (np.floor(points / cell) + 0.5) * cell
    off = np.linalg.norm(points - centre, axis=1)
    order = np.lexsort((off, group))
    return order[np.r_[True, group[order][1:] != group[order][:-1]]]
