"""Scene: target and obstacle meshes in a local metric frame, with ground and origin."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Sequence

import numpy as np
import trimesh

from coverplan.errors import InputFileError
from coverplan.geometry.clearance import ClearanceModel
from coverplan.geometry.raycast import RayCaster
from coverplan.world.prepare import prepare_mesh
from coverplan.world.terrain import Terrain

UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "ft": 0.3048, "in": 0.0254}
# Coordinates beyond this (m) are shifted to a local origin: Embree and manifold3d work
# in float32, which keeps only centimetres at 10^5 m.
LOCAL_ORIGIN_THRESHOLD = 1.0e4


@dataclass
class MeshPart:
    """One mesh of the scene and what it is.

    Parameters
    ----------
    name : str
        The part's name.
    role : {"target", "obstacle"}
        What the planner does with it.
    mesh : trimesh.Trimesh
        The mesh, metres in the local frame.
    source : str
        The file it came from.
    """

    name: str
    role: str  # "target" | "obstacle"
    mesh: trimesh.Trimesh
    source: str = ""


@dataclass
class Scene:
    """Targets and obstacles in local coordinates (source coordinates minus ``origin``).

    Made by ``load_scene`` (from files) or ``scene_from_meshes`` (from trimesh meshes).

    Parameters
    ----------
    parts : list of MeshPart
        Each mesh with its name, role ("target" or "obstacle") and source file.
    ground_z : float, optional
        Height of the flat ground in the local frame (default: the targets' lowest point).
    crs : str, optional
        The projected CRS of the source coordinates.
    origin : (3,) float
        Source coordinates of the local frame's origin (m).
    notes : list of str
        What preparing the meshes changed or found (repairs, warnings).
    vertical_crs : str, optional
        The height system of the source coordinates.
    geodetic_origin : (3,) float, optional
        [lat, lon, h]: local x, y, z are east, north, up there.
    crs_unit_m : float
        Metres per unit of the CRS (source coordinates were scaled by it).
    terrain : Terrain, optional
        The ground's heights; None: flat at ``ground_z``.
    source : dict, optional
        The files and options it was loaded from (io/scene_record.py); None: not from files.
    """

    parts: list[MeshPart]
    ground_z: float | None = None
    crs: str | None = None
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    notes: list[str] = field(default_factory=list)
    vertical_crs: str | None = None
    geodetic_origin: list | None = None
    crs_unit_m: float = 1.0
    terrain: Terrain | None = None
    source: dict | None = None
    _clearance: dict = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self):
        if not any(p.role == "target" for p in self.parts):
            raise InputFileError("scene", "no target mesh was given")
        self.origin = np.asarray(self.origin, dtype=float)
        if self.ground_z is None:
            self.ground_z = float(min(p.mesh.bounds[0, 2] for p in self.targets))

    @property
    def targets(self) -> list[MeshPart]:
        """The parts to photograph."""
        return [p for p in self.parts if p.role == "target"]

    @property
    def obstacles(self) -> list[MeshPart]:
        """The parts to keep clear of."""
        return [p for p in self.parts if p.role == "obstacle"]

    @property
    def meshes(self) -> list[trimesh.Trimesh]:
        """Every part's mesh, in the parts' order."""
        return [p.mesh for p in self.parts]

    @property
    def target_indices(self) -> np.ndarray:
        """The indices of the target parts."""
        return np.array([i for i, p in enumerate(self.parts) if p.role == "target"], dtype=int)

    def bounds(self, role: str | None = None) -> np.ndarray:
        """The box round the parts.

        Parameters
        ----------
        role : {"target", "obstacle"}, optional
            Only the parts with this role.

        Returns
        -------
        (2, 3) float
            Lower and upper corners.
        """
        parts = self.parts if role is None else [p for p in self.parts if p.role == role]
        b = np.array([p.mesh.bounds for p in parts])
        return np.array([b[:, 0].min(axis=0), b[:, 1].max(axis=0)])

    @cached_property
    def extent(self) -> float:
        """The scene's largest side, metres."""
        return float(np.ptp(self.bounds(), axis=0).max())

    @cached_property
    def epsilon(self) -> float:
        """Offset for ray origins on surfaces: above float32 noise at this scene's size."""
        reach = float(np.abs(self.bounds()).max())
        return max(1e-3, 2e-6 * reach)

    @cached_property
    def rays(self):
        """The ray caster over every mesh, the terrain as a sheet (built once)."""
        return RayCaster(self.meshes, epsilon=self.epsilon, sheets=[self.terrain.mesh] if self.terrain else [])

    def cover_edge(self, security: float) -> float:
        """The clearance models' surface-cover spacing for one security distance.

        Parameters
        ----------
        security : float
            Metres.

        Returns
        -------
        float
            Metres.
        """
        return float(np.clip(security / 2.0, self.extent / 2000.0, max(self.extent / 20.0, 1e-3)))

    def clearance_model(self, security: float):
        """Clearance queries tuned for one security distance (cached per distance).

        Parameters
        ----------
        security : float
            Metres.

        Returns
        -------
        ClearanceModel
            Distances to the scene's meshes and terrain.
        """
        edge = self.cover_edge(security)
        key = round(edge, 6)
        if key not in self._clearance:
            self._clearance[key] = ClearanceModel(self.meshes, rays=self.rays, cover_edge=edge)
        return self._clearance[key]

    def ground_at(self, xy) -> np.ndarray:
        """Ground height under each (x, y): the terrain's, or the flat ``ground_z``.

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
        return self.terrain.height(xy) if self.terrain is not None else np.full(len(xy), float(self.ground_z))

    def describe(self, index: int) -> str:
        """What a mesh index names, as messages say it ("target 'north wing'", "the ground").

        Parameters
        ----------
        index : int
            A part's index, or the terrain's (after the parts).

        Returns
        -------
        str
            The description.
        """
        if index >= len(self.parts):  # the terrain, cast after the meshes
            return f"the ground ({self.terrain.source})" if self.terrain else "the ground"
        part = self.parts[index]
        return f"{part.role} {part.name}" if "'" in part.name else f"{part.role} '{part.name}'"

    @property
    def frame(self) -> dict:
        """Where the local frame sits on Earth, as the route file records it."""
        frame = {"crs": self.crs, "origin": self.origin.tolist()}
        if self.vertical_crs:
            frame["vertical_crs"] = self.vertical_crs
        if self.geodetic_origin:
            frame["geodetic_origin"] = [float(v) for v in self.geodetic_origin]
        if self.crs and self.crs_unit_m != 1.0:
            frame["crs_unit_m"] = self.crs_unit_m
        return frame

    def to_source(self, points) -> np.ndarray:
        """Local coordinates back to the source frame.

        Parameters
        ----------
        points : (n, 3) float
            Local coordinates.

        Returns
        -------
        (n, 3) float
            Source coordinates, metres.
        """
        return np.asarray(points, dtype=float) + self.origin

    def to_local(self, points) -> np.ndarray:
        """Points in the input models' coordinates (metres) into the local frame.

        Parameters
        ----------
        points : (n, 3) float
            Source coordinates, metres.

        Returns
        -------
        (n, 3) float
            Local coordinates.
        """
        return np.asarray(points, dtype=float) - self.origin


def build_scene(parts: Sequence[MeshPart], *, ground: float | None = None, crs: str | None = None,
                vertical_crs: str | None = None, notes: Sequence[str] = ()) -> Scene:
    """Prepare meshes already in metres and move far-away coordinates to a local origin.

    Parameters
    ----------
    parts : sequence of MeshPart
        The meshes.
    ground : float, optional
        The ground's height in the source frame; the lowest vertex when None.
    crs : str, optional
        The source coordinates' CRS.
    vertical_crs : str, optional
        The heights' datum.
    notes : sequence of str
        Notes kept with the scene.

    Returns
    -------
    Scene
        The scene.
    """
    notes = list(notes)
    prepared = []
    for part in parts:
        mesh, part_notes = prepare_mesh(part.mesh, part.name)
        prepared.append(MeshPart(part.name, part.role, mesh, part.source))
        notes += part_notes
    origin = np.zeros(3)
    corner = np.array([p.mesh.bounds for p in prepared if p.role == "target"]).reshape(-1, 3)
    if len(corner) and np.abs(corner).max() > LOCAL_ORIGIN_THRESHOLD:
        center = corner.mean(axis=0)
        origin = np.where(np.abs(center) > LOCAL_ORIGIN_THRESHOLD, np.round(center), 0.0)
        for part in prepared:
            part.mesh.apply_translation(-origin)
        notes.append(f"moved to a local origin at {origin.tolist()} (source coordinates are far from 0)")
    ground_local = None if ground is None else float(ground) - origin[2]
    return Scene(prepared, ground_z=ground_local, crs=crs, origin=origin, notes=notes, vertical_crs=vertical_crs)


def scene_from_meshes(targets: Sequence[trimesh.Trimesh], obstacles: Sequence[trimesh.Trimesh] = (),
                      ground: float | None = None) -> Scene:
    """A Scene from in-memory meshes (metres), named target0.., obstacle0..

    Parameters
    ----------
    targets : sequence of trimesh.Trimesh
        The target's meshes.
    obstacles : sequence of trimesh.Trimesh
        Obstacles.
    ground : float, optional
        The ground's height.

    Returns
    -------
    Scene
        The scene.
    """
    parts = [MeshPart(f"target{i}", "target", m.copy()) for i, m in enumerate(targets)]
    parts += [MeshPart(f"obstacle{i}", "obstacle", m.copy()) for i, m in enumerate(obstacles)]
    return build_scene(parts, ground=ground)
