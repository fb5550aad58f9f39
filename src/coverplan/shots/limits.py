"""What a viewpoint must satisfy, shared by the planner and the evaluator: security distance, range, incidence, gimbal, altitude band, ceiling and zones."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from coverplan.world.terrain import Terrain
from coverplan.world.zones import Zones


@dataclass
class ViewLimits:
    """What a viewpoint must satisfy, shared by the evaluator and the planner.

    Parameters
    ----------
    security : float
        The security distance, metres.
    d_opt : float
        The optimal distance, metres.
    max_incidence_deg : float
        The largest incidence a view may have.
    min_z : float
        The lowest height the drone may fly at (the lowest floor over terrain), metres.
    pitch_range_deg : (float, float)
        The gimbal's lowest and highest pitch.
    vfov_deg : float
        The camera's vertical field of view.
    ground_z : float
        The flat ground's height.
    terrain : Terrain, optional
        The ground, when not flat.
    envelope : Terrain, optional
        Over terrain, the lowest heights ``security`` clear of the ground in 3D.
    max_altitude : float
        The ceiling, metres above the ground under the drone.
    zones : Zones
        Keep-out and keep-in prisms.
    """

    security: float
    d_opt: float
    max_incidence_deg: float
    min_z: float
    pitch_range_deg: tuple[float, float]
    vfov_deg: float
    ground_z: float = -np.inf
    terrain: Terrain | None = None  # with it, min_z is the lowest floor and the floor follows the ground
    # Over terrain: the lowest heights ``security`` clear of the ground in 3D (the floor rises
    # to it over slopes, where the minimum altitude alone comes closer than that).
    envelope: Terrain | None = None
    max_altitude: float = np.inf  # the ceiling, m above the ground under the drone
    zones: Zones = Zones()  # keep-out and keep-in prisms

    @property
    def min_altitude(self) -> float:
        """The minimum altitude above the ground, metres."""
        return self.min_z - self.ground_z

    def ground_at(self, xy) -> np.ndarray:
        """Ground height under each (x, y).

        Parameters
        ----------
        xy : (n, 2) float
            Local coordinates.

        Returns
        -------
        (n,) float
            Metres.
        """
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        return self.terrain.height(xy) if self.terrain is not None else np.full(len(xy), self.ground_z)

    def floor_at(self, xy) -> np.ndarray:
        """The lowest height the drone may fly at over each (x, y).

        Parameters
        ----------
        xy : (n, 2) float
            Local coordinates.

        Returns
        -------
        (n,) float
            Metres.
        """
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        if self.terrain is None:
            return np.full(len(xy), self.min_z)
        floor = self.terrain.height(xy) + self.min_altitude
        return floor if self.envelope is None else np.maximum(floor, self.envelope.height(xy))

    def above_floor(self, points, tol: float = 1e-9) -> np.ndarray:
        """Whether each point keeps the minimum altitude.

        Parameters
        ----------
        points : (n, 3) float
            Local coordinates.
        tol : float
            Metres.

        Returns
        -------
        (n,) bool
            True at or above the floor.
        """
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        return points[:, 2] >= self.floor_at(points[:, :2]) - tol

    def segments_above_floor(self, starts, ends, tol: float = 1e-6) -> np.ndarray:
        """Whether every point of each segment keeps the minimum altitude (over flat ground the
        ends settle it; over terrain every crossing of the ground's grid is checked) and, over
        terrain, the security distance from the ground in 3D.

        Parameters
        ----------
        starts, ends : (n, 3) float
            The segments.
        tol : float
            Metres.

        Returns
        -------
        (n,) bool
            Segments that keep it.
        """
        starts = np.asarray(starts, dtype=float).reshape(-1, 3)
        ends = np.asarray(ends, dtype=float).reshape(-1, 3)
        if self.terrain is None:
            return (starts[:, 2] >= self.min_z - tol) & (ends[:, 2] >= self.min_z - tol)
        ok = self.terrain.segments_above(starts, ends, self.min_altitude, tol)
        if self.envelope is not None and ok.any():
            ok[ok] = self.envelope.segments_above(starts[ok], ends[ok], 0.0, tol)
        return ok

    def below_ceiling(self, points, tol: float = 1e-9) -> np.ndarray:
        """Whether each point is at most ``max_altitude`` above the ground under it.

        Parameters
        ----------
        points : (n, 3) float
            Local coordinates.
        tol : float
            Metres.

        Returns
        -------
        (n,) bool
            True at or below the ceiling.
        """
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        if not np.isfinite(self.max_altitude):
            return np.ones(len(points), dtype=bool)
        return points[:, 2] - self.ground_at(points[:, :2]) <= self.max_altitude + tol

    def allowed(self, points, tol: float = 1e-9) -> np.ndarray:
        """Where the drone may be: above the floor, below the ceiling, outside every keep-out
        zone and inside the keep-in region.

        Parameters
        ----------
        points : (n, 3) float
            Local coordinates.
        tol : float
            Metres.

        Returns
        -------
        (n,) bool
            Allowed points.
        """
        ok = self.above_floor(points, tol) & self.below_ceiling(points, tol)
        if self.zones and ok.any():
            ok[ok] = self.zones.points_allowed(np.asarray(points, dtype=float).reshape(-1, 3)[ok])
        return ok

    def segments_below_ceiling(self, starts, ends, tol: float = 1e-6) -> np.ndarray:
        """Whether every point of each segment stays below the ceiling (over flat ground the
        ends settle it; over terrain every crossing of the ground's grid is checked).

        Parameters
        ----------
        starts, ends : (n, 3) float
            The segments.
        tol : float
            Metres.

        Returns
        -------
        (n,) bool
            Segments that keep it.
        """
        starts = np.asarray(starts, dtype=float).reshape(-1, 3)
        ends = np.asarray(ends, dtype=float).reshape(-1, 3)
        if not np.isfinite(self.max_altitude):
            return np.ones(len(starts), dtype=bool)
        ok = self.below_ceiling(starts, tol) & self.below_ceiling(ends, tol)
        if self.terrain is not None and ok.any():
            ok[ok] = self.terrain.highest_above(starts[ok], ends[ok]) <= self.max_altitude + tol
        return ok

    def segments_allowed(self, starts, ends, tol: float = 1e-6) -> np.ndarray:
        """Whether every point of each segment keeps above the floor and below the ceiling,
        out of every keep-out zone and in the keep-in region.

        Parameters
        ----------
        starts, ends : (n, 3) float
            The segments.
        tol : float
            Metres.

        Returns
        -------
        (n,) bool
            Allowed segments.
        """
        starts = np.asarray(starts, dtype=float).reshape(-1, 3)
        ends = np.asarray(ends, dtype=float).reshape(-1, 3)
        ok = self.segments_above_floor(starts, ends, tol)
        if np.isfinite(self.max_altitude) and ok.any():
            ok[ok] = self.segments_below_ceiling(starts[ok], ends[ok], tol)
        if self.zones and ok.any():
            ok[ok] = self.zones.segments_allowed(starts[ok], ends[ok])
        return ok

    def lowest_floor(self, lo_xy, hi_xy) -> float:
        """The lowest the drone may fly anywhere over the box [lo_xy, hi_xy].

        Parameters
        ----------
        lo_xy, hi_xy : (2,) float
            The box's corners.

        Returns
        -------
        float
            Metres.
        """
        if self.terrain is None:
            return self.min_z
        return self.terrain.lowest_in(np.asarray(lo_xy)[:2], np.asarray(hi_xy)[:2]) + self.min_altitude

    def elevation_ok(self, rays) -> np.ndarray:
        """Whether the gimbal can frame a point seen along ``rays`` (point -> camera).

        Parameters
        ----------
        rays : (n, 3) float
            Unit vectors, point to camera.

        Returns
        -------
        (n,) bool
            Framable rays.
        """
        elevation = -np.degrees(np.arcsin(np.clip(rays[:, 2], -1, 1)))  # of the point, from the camera
        lo, hi = self.pitch_range_deg
        half = self.vfov_deg / 2.0
        return (elevation >= lo - half) & (elevation <= hi + half)


def scene_limits(scene, *, security: float, d_opt: float, max_incidence_deg: float, min_altitude: float,
                pitch_range_deg, vfov_deg: float, max_altitude: float | None = None,
                zones: Zones = Zones()) -> ViewLimits:
    """The limits over this scene's ground: flat at ``scene.ground_z``, or its terrain (then
    ``min_z`` is the lowest floor near the target and the floor follows the ground).

    Parameters
    ----------
    scene : Scene
        The scene.
    security : float
        Metres.
    d_opt : float
        Metres.
    max_incidence_deg : float
        Degrees.
    min_altitude : float
        Metres above the ground.
    pitch_range_deg : (float, float)
        The gimbal's range.
    vfov_deg : float
        The camera's vertical field of view.
    max_altitude : float, optional
        The ceiling above the ground.
    zones : Zones
        Keep-out and keep-in prisms.

    Returns
    -------
    ViewLimits
        The limits.
    """
    ground = float(scene.ground_z)
    if scene.terrain is not None:
        lo, hi = scene.bounds("target")
        reach = d_opt + security
        ground = scene.terrain.lowest_in(lo[:2] - reach, hi[:2] + reach)
    envelope = None if scene.terrain is None else scene.terrain.clearance_envelope(float(security))
    return ViewLimits(float(security), float(d_opt), float(max_incidence_deg), ground + float(min_altitude),
                      tuple(float(v) for v in pitch_range_deg), float(vfov_deg), ground, scene.terrain, envelope,
                      np.inf if max_altitude is None else float(max_altitude), zones)
