"""The thesis's planner end to end: 2D slices (3.2-3.4) and the 3D approach (3.5).

Each path is a separate flight (initial, coverage, final), as in the thesis: façades slice
by slice with vertical moves between slices; rooftop, terraces and opposed terraces each
solved as 2D problems on a shrinking target region, flown at a height fixed by a 45 deg
pitch and d_opt. The known failures are kept: obstacles between slices are not seen, a
surface point no viewpoint sees makes that path fail, shots are linked pair by pair. The
result is the same route file as the mesh planner's (grid cells -> metres).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from coverplan.equipment.camera import Camera
from coverplan.flight.route import Route, coverage_length, polyline_length
from coverplan.voxel.grid import FREE, OBSTACLE, TARGET, SceneGrid, grid_from_scene
from coverplan.voxel.path import cell_path, cost_grid, grid_graph
from coverplan.voxel.view import view_plan

PITCH_DEG = 45.0  # fixed pitch of rooftop / terrace (down) and opposed-terrace (up) shots


def thesis_camera() -> Camera:
    """80 deg horizontal FOV with the thesis's 10 m vertical coverage at d_opt = 7 m.

    Returns
    -------
    Camera
        The thesis's camera.
    """
    focal = 18.0 / np.tan(np.radians(40.0))
    height = 2 * focal * np.tan(np.arctan(5.0 / 7.0))
    return Camera(36.0, height, focal, 6000, int(round(6000 * height / 36.0)), "thesis80x71")


@dataclass
class Flight:
    """One of the thesis's paths: waypoints in metres and what happened.

    Parameters
    ----------
    name : str
        The path's name (façade, rooftop, terrace ...).
    positions : list of (3,) float
        Waypoints, metres.
    shot : list of bool
        Whether each waypoint takes a photo.
    heading, pitch : list of float
        Degrees.
    failure : str, optional
        Why the path stopped short.
    seconds : float
        Planning time.
    """

    name: str
    positions: list = field(default_factory=list)
    shot: list = field(default_factory=list)
    heading: list = field(default_factory=list)
    pitch: list = field(default_factory=list)
    failure: str | None = None
    seconds: float = 0.0

    @property
    def n_shots(self) -> int:
        """How many waypoints take a photo."""
        return int(sum(self.shot))

    @property
    def length(self) -> float:
        """The path's length, metres."""
        return polyline_length(self.positions)

    @property
    def coverage_length(self) -> float:
        """Length from the first shot to the last (the thesis's tables count only this)."""
        return coverage_length(self.positions, self.shot)

    def add(self, position, shot=False, heading=0.0, pitch=0.0):
        """Append a waypoint.

        Parameters
        ----------
        position : (3,) float
            Metres.
        shot : bool
            Whether it takes a photo.
        heading, pitch : float
            Degrees.
        """
        self.positions.append(np.asarray(position, dtype=float))
        self.shot.append(bool(shot))
        self.heading.append(float(heading))
        self.pitch.append(float(pitch))


@dataclass
class VoxelPlan:
    """The thesis planner's result: the route, its separate paths and the grid planned on.

    Parameters
    ----------
    route : Route or None
        The paths joined as one route; None when nothing was planned.
    flights : list of Flight
        The thesis's separate paths.
    grid : SceneGrid
        The rasterised scene.
    seconds : float
        Planning time.
    """
    route: Route | None
    flights: list[Flight]
    grid: SceneGrid
    seconds: float

    @property
    def failures(self) -> list[str]:
        """One line per path that stopped short, with why."""
        return [f"{f.name}: {f.failure}" for f in self.flights if f.failure]


def _heading(yaw: float) -> float:
    """Grid yaw (radians, counter-clockwise from +x) as a heading (degrees clockwise from north)."""
    return float((90.0 - np.degrees(yaw)) % 360.0)


class _Layer:
    """A 2D grid at one flight height, with its cost graph (built once)."""

    def __init__(self, cells: np.ndarray, grid: SceneGrid, z: float, d_opt: float, d_sec: float):
        self.cells, self.grid, self.z = cells, grid, z
        self.cost = cost_grid(cells, d_opt, d_sec)
        self.graph = grid_graph(self.cost)

    def metres(self, cell) -> np.ndarray:
        xy = self.grid.origin[:2] + (np.asarray(cell, dtype=float) + 0.5) * self.grid.cell
        return np.array([xy[0], xy[1], self.z])

    def cell_of(self, xy) -> np.ndarray:
        return np.clip(np.floor((np.asarray(xy[:2], float) - self.grid.origin[:2]) / self.grid.cell).astype(int),
                       0, np.array(self.cells.shape) - 1)

    def walk(self, flight: Flight, a, b) -> bool:
        """Append the Dijkstra path from cell a to cell b (a excluded); False if there is none."""
        cells = cell_path(self.graph, self.cells.shape, a, b)
        if cells is None:
            return False
        for c in cells[1:]:
            flight.add(self.metres(c))
        return True


def _cover_layer(flight: Flight, layer: _Layer, d_opt, d_sec, hfov, pitch, range_capped,
                 facing_free_only: bool = False) -> np.ndarray | None:
    """Viewpoints of one 2D problem flown from the flight's current position; returns the cell
    the flight ends at, or None (and sets the failure) when the thesis finds no path."""
    here = layer.cell_of(flight.positions[-1])
    vp = view_plan(layer.cells, d_opt, d_sec, hfov, here + 0.5, range_capped=range_capped,
                   facing_free_only=facing_free_only)
    if vp.failure:
        flight.failure = vp.failure
        return None
    for cell, yaw in zip(vp.cells, vp.yaw):
        if not layer.walk(flight, here, cell):
            flight.failure = f"no path to the viewpoint at cell {tuple(int(c) for c in cell)}"
            return None
        flight.add(layer.metres(cell), True, _heading(yaw), pitch)
        here = cell
    return here


def _climb(flight: Flight, z: float) -> None:
    """The thesis's vertical move between levels."""
    p = flight.positions[-1].copy()
    if abs(p[2] - z) > 1e-9:
        p[2] = z
        flight.add(p)


def _return(flight: Flight, layer: _Layer, here, start) -> None:
    if not layer.walk(flight, here, layer.cell_of(start)):
        flight.failure = "no path back to the initial point"
        return
    _climb(flight, start[2])
    flight.add(start)


def facade_flight(grid: SceneGrid, start, d_opt, d_sec, hfov, vertical_coverage, top, range_capped) -> Flight:
    """Slices spaced by the vertical coverage up to the rooftop, linked by vertical moves.

    Parameters
    ----------
    grid : SceneGrid
        The 3D grid.
    start : (3,) float
        The initial point, metres.
    d_opt, d_sec : float
        Optimal and security distances, metres.
    hfov : float
        The camera's horizontal field of view, degrees.
    vertical_coverage : float
        Metres of wall a photo covers at d_opt: the slices' spacing.
    top : float
        The rooftop's height, metres.
    range_capped : bool
        A viewpoint sees only points within d_opt.

    Returns
    -------
    Flight
        The façade path.
    """
    flight = Flight("facades")
    flight.add(start)
    z = grid.origin[2] + vertical_coverage / 2.0
    here, layer = None, None
    while z < top:
        layer = _Layer(grid.slice_at(z).cells, grid, z, d_opt / grid.cell, d_sec / grid.cell)
        _climb(flight, z)
        here = _cover_layer(flight, layer, d_opt / grid.cell, d_sec / grid.cell, hfov, 0.0, range_capped)
        if here is None:
            return flight
        z += vertical_coverage
    if layer is not None:
        _return(flight, layer, here, start)
    return flight


def special_regions(grid: SceneGrid) -> list[tuple[str, int, np.ndarray]]:
    """(kind, layer, 2D mask) of rooftops, terraces and opposed terraces in a 3D grid.

    Up-facing cells (target with free above) per layer; the highest layer is the rooftop, the
    others terraces. Down-facing cells above the ground are opposed terraces. One-cell-wide
    steps (a gradual slope, as on the thesis's pyramid) are not terraces: an opening removes them.

    Parameters
    ----------
    grid : SceneGrid
        The 3D grid.

    Returns
    -------
    list of (str, int, (nx, ny) bool)
        Kind (``rooftop``, ``terrace``, ``opposed``), layer and mask.
    """
    cells = grid.cells
    target = cells == TARGET
    free = cells == FREE
    up = target[:, :, :-1] & free[:, :, 1:]
    down = target[:, :, 1:] & free[:, :, :-1]
    out = []
    levels = [k for k in range(up.shape[2]) if up[:, :, k].any()]
    for k in levels:
        mask = ndimage.binary_opening(up[:, :, k], structure=np.ones((3, 3)))
        if k == levels[-1]:
            mask = up[:, :, k]  # the rooftop is kept however small
        if mask.any():
            out.append(("rooftop" if k == levels[-1] else "terrace", k, mask))
    for k in range(down.shape[2]):
        mask = ndimage.binary_opening(down[:, :, k], structure=np.ones((3, 3)))
        if mask.any():
            out.append(("opposed terrace", k + 1, mask))
    return out


def special_flight(grid: SceneGrid, kind: str, level: int, mask: np.ndarray, start, d_opt, d_sec, hfov,
                   band: float, range_capped) -> Flight:
    """Cover a rooftop / terrace / opposed terrace by 2D problems on a shrinking region.

    Each round flies round the region's edge towards free space, looking at it at 45 deg; the
    region then loses a band of the width assumed seen inwards, until nothing is left.

    Parameters
    ----------
    grid : SceneGrid
        The 3D grid.
    kind : str
        ``rooftop``, ``terrace`` or ``opposed``.
    level : int
        The region's layer.
    mask : (nx, ny) bool
        The region.
    start : (3,) float
        The initial point, metres.
    d_opt, d_sec : float
        Optimal and security distances, metres.
    hfov : float
        Horizontal field of view, degrees.
    band : float
        The width seen inwards per round, metres.
    range_capped : bool
        A viewpoint sees only points within d_opt.

    Returns
    -------
    Flight
        The region's path.
    """
    up = kind != "opposed terrace"
    # up-facing: the top face of layer ``level``; down-facing: the bottom face of layer ``level``
    surface_z = grid.origin[2] + (level + (1 if up else 0)) * grid.cell
    flight = Flight(f"{kind} at {surface_z:.1f} m")
    flight.add(start)
    z = surface_z + (1 if up else -1) * d_opt * np.sin(np.radians(PITCH_DEG))
    flying = grid.slice_at(z).cells
    region = mask.copy()
    steps = max(int(round(band / grid.cell)), 1)
    here, layer = None, None
    _climb(flight, z)
    while region.any():
        cells = np.where(flying != FREE, OBSTACLE, FREE).astype(np.int8)
        cells[region] = TARGET
        layer = _Layer(cells, grid, z, d_opt / grid.cell, d_sec / grid.cell)
        here = _cover_layer(flight, layer, d_opt / grid.cell, d_sec / grid.cell, hfov,
                            -PITCH_DEG if up else PITCH_DEG, range_capped, facing_free_only=True)
        if here is None:
            return flight
        # shrink from the free side only: the band just flown is seen
        outside = (flying == FREE) & ~region
        region &= ndimage.distance_transform_edt(~outside) > steps
    if layer is not None:
        _return(flight, layer, here, start)
    return flight


def plan_3d(scene, camera, gsd: float, security: float, start, cell: float = 1.0,
            range_capped: bool = False, vertical_coverage: float | None = None) -> VoxelPlan:
    """The thesis's 3D approach on the scene rasterised at ``cell`` metres.

    Parameters
    ----------
    scene : Scene
        The scene planned.
    camera : Camera
        The camera flown.
    gsd : float
        Metres per pixel at d_opt.
    security : float
        The security distance, metres.
    start : (3,) float
        The initial point.
    cell : float
        The cell size, metres.
    range_capped : bool
        A viewpoint sees only points within d_opt.
    vertical_coverage : float, optional
        The slices' spacing; the camera's vertical footprint at d_opt when None.

    Returns
    -------
    VoxelPlan
        The paths and the route.
    """
    t0 = time.perf_counter()
    d_opt = camera.optimal_distance(gsd)
    if vertical_coverage is None:
        vertical_coverage = camera.footprint(d_opt)[1]
    grid = grid_from_scene(scene, cell, margin=d_opt + security + 2 * cell)
    start = np.asarray(start, dtype=float)
    top = scene.bounds("target")[1, 2]
    flights = []
    for kind, level, mask in special_regions(grid):
        t = time.perf_counter()
        f = special_flight(grid, kind, level, mask, start, d_opt, security, camera.hfov_deg,
                           vertical_coverage / 2.0, range_capped)
        f.seconds = time.perf_counter() - t
        flights.append(f)
    t = time.perf_counter()
    f = facade_flight(grid, start, d_opt, security, camera.hfov_deg, vertical_coverage, top, range_capped)
    f.seconds = time.perf_counter() - t
    flights.append(f)
    route = _route(flights, camera, gsd, security, scene)
    return VoxelPlan(route, flights, grid, time.perf_counter() - t0)


def plan_2d(grid: SceneGrid, camera, gsd: float, security: float, start, z: float = 0.5,
            range_capped: bool = False, scene=None) -> VoxelPlan:
    """The thesis's 2D planner on one grid, flown at height ``z``.

    Parameters
    ----------
    grid : SceneGrid
        A 2D grid.
    camera : Camera
        The camera flown.
    gsd : float
        Metres per pixel at d_opt.
    security : float
        The security distance, metres.
    start : (2,) float
        The initial point, metres.
    z : float
        The flying height, metres.
    range_capped : bool
        A viewpoint sees only points within d_opt.
    scene : Scene, optional
        The scene the route is checked against.

    Returns
    -------
    VoxelPlan
        One path and its route.
    """
    t0 = time.perf_counter()
    d_opt = camera.optimal_distance(gsd)
    start = np.array([start[0], start[1], z], dtype=float)
    flight = Flight("slice")
    flight.add(start)
    layer = _Layer(grid.cells, grid, z, d_opt / grid.cell, security / grid.cell)
    here = _cover_layer(flight, layer, d_opt / grid.cell, security / grid.cell, camera.hfov_deg, 0.0, range_capped)
    if here is not None:
        _return(flight, layer, here, start)
    flight.seconds = time.perf_counter() - t0
    return VoxelPlan(_route([flight], camera, gsd, security, scene), [flight], grid, flight.seconds)


def _route(flights: list[Flight], camera, gsd, security, scene) -> Route | None:
    """One route file: the successful flights one after the other, each from the start and back."""
    good = [f for f in flights if not f.failure and f.n_shots]
    if not good:
        return None
    pos = np.vstack([np.array(f.positions) for f in good])
    shot = np.concatenate([f.shot for f in good])
    heading = np.concatenate([f.heading for f in good])
    pitch = np.concatenate([f.pitch for f in good])
    rows = np.flatnonzero(shot)
    legs = ["initial" if k < rows[0] else "final" if k > rows[-1] else "coverage" for k in range(len(pos))]
    params = {"gsd_m": gsd, "security_m": security, "min_views": 2, "min_triangulation_deg": 5.0,
              "max_incidence_deg": 70.0, "min_altitude_m": 0.0, "gimbal_pitch_range_deg": [-90.0, 90.0]}
    frame = {"crs": None, "origin": [0.0, 0.0, 0.0]}
    if scene is not None:
        params["ground_z_m"] = scene.ground_z
        frame = scene.frame
    route = Route(pos, shot, heading, pitch, legs, camera, params, frame=frame)
    route.extra = {"planner": "voxel baseline (thesis chapter 3)", "flights": [f.name for f in good],
                   "failures": [f"{f.name}: {f.failure}" for f in flights if f.failure]}
    return route
