"""The flight people fly today: QGroundControl's Structure Scan round the target's footprint.

Rules as QGroundControl's Structure Scan applies them, by the same expansion ``evaluate`` uses
to read a Structure Scan from a ``.plan`` (``coverplan.io.qgc_complex``): the outline a surveyor
would draw (the footprint, with the notches the scan distance cannot enter closed) offset
outward by the scan distance, each vertex where the offset edges meet (mitred); layers from
half a frame above the lowest allowed height, a frame apart (the image's vertical footprint
times 1 - front overlap), up to the top of the structure; photos every horizontal footprint
times (1 - side overlap) along each layer from its first vertex; the camera level and 90 deg
right of the way flown, so it faces each wall square-on and turns at the vertices. The scan
distance is the one our planner flies at the same GSD, so the two are compared at the same
detail. Layers are flown bottom to top from the vertex nearest the start, and the flight
returns to the start. The roof grid is QGroundControl's Survey: transects along the
footprint's longer side, the drone facing the way it flies.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.ops import unary_union

from coverplan.flight.route import Route
from coverplan.io.qgc_complex import flight_polygon, layer_stops
from coverplan.planning.settings import safety_margin
from coverplan.shots.candidates import standoff
from coverplan.shots.limits import ViewLimits


def footprint(scene):
    """The target's footprint: the union of its triangles projected on the ground plane."""
    polys = []
    for part in scene.targets:
        tri = part.mesh.vertices[part.mesh.faces][:, :, :2]
        a, b = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        area = np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
        polys.extend(shapely.polygons(tri[area > 1e-9]))
    return unary_union(polys).buffer(0)


def scan_outline(scene, distance: float) -> np.ndarray:
    """(n, 2) the outline a surveyor draws for the scan: the footprint's outer ring with the
    notches narrower than twice the scan distance closed (the scan cannot enter them), its
    vertices no closer than a metre."""
    base = footprint(scene)
    closed = base.buffer(distance, join_style="mitre").buffer(-distance, join_style="mitre")
    poly = max(getattr(closed, "geoms", [closed]), key=lambda g: g.area).simplify(0.5)
    return np.asarray(poly.exterior.coords)[:-1]


def structure_scan(scene, camera, gsd: float, security: float, start, front_overlap: float = 0.7,
                   side_overlap: float = 0.7, min_altitude: float | None = None) -> Route:
    """A Structure Scan route (level camera, layered loops of the mitred offset) at the
    planner's standoff."""
    d_opt = camera.optimal_distance(gsd)
    min_alt = security if min_altitude is None else float(min_altitude)
    limits = ViewLimits(security, d_opt, 70.0, scene.ground_z + min_alt, (-90.0, 30.0), camera.vfov_deg, scene.ground_z)
    distance = standoff(camera, limits, safety_margin(security))
    width, height = camera.footprint(distance)
    layer_step = height * (1.0 - front_overlap)
    photo_step = width * (1.0 - side_overlap)
    top = scene.bounds("target")[1, 2]
    ring = flight_polygon(scan_outline(scene, distance), distance)
    start = np.asarray(start, dtype=float)
    ring = np.roll(ring, -int(np.argmin(np.linalg.norm(ring - start[:2], axis=1))), axis=0)
    stops = layer_stops(np.vstack([ring, ring[:1]]), photo_step)
    xy = np.array([p for p, _h, _s in stops])
    heading = np.array([h for _p, h, _s in stops])
    photo = np.array([s for _p, _h, s in stops])
    layers = max(int(np.ceil(max(top - limits.min_z, 0.0) / layer_step - 1e-9)), 1)
    heights = limits.min_z + layer_step * (np.arange(layers) + 0.5)
    positions, shot, headings = [start], [False], [0.0]
    for z in heights:
        positions.extend(np.column_stack([xy, np.full(len(xy), z)]))
        shot.extend(photo)
        headings.extend(heading)
    positions.append(start)
    shot.append(False)
    headings.append(0.0)
    positions = np.array(positions)
    legs = ["initial"] + ["coverage"] * (len(positions) - 2) + ["final"]
    params = {"gsd_m": gsd, "security_m": security, "min_views": 2, "min_triangulation_deg": 5.0,
              "max_incidence_deg": 70.0, "min_altitude_m": min_alt, "ground_z_m": scene.ground_z,
              "gimbal_pitch_range_deg": [-90.0, 30.0], "rule": "structure-scan",
              "front_overlap": front_overlap, "side_overlap": side_overlap}
    route = Route(positions, np.array(shot), np.array(headings), np.zeros(len(positions)), legs, camera,
                  params, frame=scene.frame)
    route.metrics = {"shots": int(np.sum(shot)), "layers": int(len(heights)), "scan_distance_m": distance}
    return route


def roof_grid(scene, camera, gsd: float, security: float, front_overlap: float = 0.7, side_overlap: float = 0.7):
    """A nadir grid over the target's footprint, as QGroundControl's Survey flies it: lanes along
    the footprint's longer side, photos spaced by the image footprint times (1 - overlap), at the
    height above the roof's top where the GSD holds (the planner's standoff), never below the
    security distance. Returns the photo positions (n, 3) in flight order and their headings
    (n,): the way the drone flies, as a multirotor's survey faces it."""
    d_opt = camera.optimal_distance(gsd)
    limits = ViewLimits(security, d_opt, 70.0, scene.ground_z + security, (-90.0, 30.0), camera.vfov_deg, scene.ground_z)
    distance = max(standoff(camera, limits, safety_margin(security)), security + safety_margin(security))
    width, height = camera.footprint(distance)
    base = footprint(scene)
    area = base.buffer(0.5 * min(width, height))
    x0, y0, x1, y1 = area.bounds
    z = scene.bounds("target")[1, 2] + distance
    along_x = (x1 - x0) >= (y1 - y0)
    # Image width across the lanes (heading along the lane: the long side sweeps sideways).
    lane_step, photo_step = width * (1.0 - side_overlap), height * (1.0 - front_overlap)
    if along_x:
        lanes = np.arange(y0, y1 + lane_step, lane_step)
        stops = np.arange(x0, x1 + photo_step, photo_step)
    else:
        lanes = np.arange(x0, x1 + lane_step, lane_step)
        stops = np.arange(y0, y1 + photo_step, photo_step)
    out = []
    for k, lane in enumerate(lanes):
        run = stops if k % 2 == 0 else stops[::-1]
        pts = np.column_stack([run, np.full(len(run), lane)]) if along_x else np.column_stack([np.full(len(run), lane), run])
        keep = shapely.contains_xy(area, pts[:, 0], pts[:, 1])
        out.extend(np.column_stack([pts[keep], np.full(int(keep.sum()), z)]))
    out = np.array(out).reshape(-1, 3)
    return out, _travel_headings(out)


def _travel_headings(points: np.ndarray) -> np.ndarray:
    """(n,) the heading of the way flown to each photo (from it, at the first), degrees."""
    if len(points) < 2:
        return np.zeros(len(points))
    step = np.diff(points[:, :2], axis=0)
    heading = np.degrees(np.arctan2(step[:, 0], step[:, 1])) % 360.0
    return np.r_[heading[0], heading]


def scan_with_roof_grid(scene, camera, gsd: float, security: float, start, overlap: float = 0.7) -> Route:
    """The Structure Scan, then a nadir roof grid at the same overlaps: what surveyors fly when
    the roof matters. The grid is flown after the top layer, then back to the start."""
    scan = structure_scan(scene, camera, gsd, security, start, overlap, overlap)
    grid, grid_heading = roof_grid(scene, camera, gsd, security, overlap, overlap)
    pos = np.vstack([scan.positions[:-1], grid, scan.positions[-1:]])
    shot = np.concatenate([scan.shot[:-1], np.ones(len(grid), bool), [False]])
    heading = np.concatenate([scan.heading_deg[:-1], grid_heading, [0.0]])
    pitch = np.concatenate([scan.pitch_deg[:-1], np.full(len(grid), -90.0), [0.0]])
    legs = ["initial"] + ["coverage"] * (len(pos) - 2) + ["final"]
    params = dict(scan.params, rule="structure-scan+roof-grid")
    route = Route(pos, shot, heading, pitch, legs, camera, params, frame=scene.frame)
    route.metrics = dict(scan.metrics, shots=int(shot.sum()), roof_grid_shots=int(len(grid)))
    return route
