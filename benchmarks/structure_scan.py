"""The flight people fly today: QGroundControl's Structure Scan around the target's footprint.

Rules as QGroundControl's Structure Scan applies them: the footprint polygon offset by the scan
distance; layers from the lowest allowed height to the top of the structure, spaced by the
image's vertical footprint times (1 - front overlap); photos along each layer spaced by the
horizontal footprint times (1 - side overlap); the camera level (gimbal pitch 0) and facing the
structure. The scan distance is the one our planner flies at the same GSD, so the two are
compared at the same detail. Layers are flown bottom to top, each entered at the point
nearest the previous one, and the flight returns to the start.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.ops import unary_union

from coverplan.flight.route import Route
from coverplan.geometry.orientation import heading_pitch
from coverplan.planning.settings import safety_margin
from coverplan.shots.candidates import standoff
from coverplan.shots.reachability import ViewLimits


def footprint(scene):
    """The target's footprint: the union of its triangles projected on the ground plane."""
    polys = []
    for part in scene.targets:
        tri = part.mesh.vertices[part.mesh.faces][:, :, :2]
        a, b = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        area = np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
        polys.extend(shapely.polygons(tri[area > 1e-9]))
    return unary_union(polys).buffer(0)


def structure_scan(scene, camera, gsd: float, security: float, start, front_overlap: float = 0.7,
                   side_overlap: float = 0.7, min_altitude: float | None = None) -> Route:
    """A Structure Scan route (level camera, layered orbits) at the planner's standoff."""
    d_opt = camera.optimal_distance(gsd)
    min_alt = security if min_altitude is None else float(min_altitude)
    limits = ViewLimits(security, d_opt, 70.0, scene.ground_z + min_alt, (-90.0, 30.0), camera.vfov_deg, scene.ground_z)
    distance = standoff(camera, limits, safety_margin(security))
    width, height = camera.footprint(distance)
    layer_step = height * (1.0 - front_overlap)
    photo_step = width * (1.0 - side_overlap)
    top = scene.bounds("target")[1, 2]
    base = footprint(scene)
    ring = base.buffer(distance, quad_segs=8)
    ring = max(getattr(ring, "geoms", [ring]), key=lambda g: g.area).exterior
    n = max(3, int(np.ceil(ring.length / photo_step)))
    xy = np.array([ring.interpolate(k * ring.length / n).coords[0] for k in range(n)])
    nearest = np.array([shapely.get_coordinates(shapely.shortest_line(shapely.points(p), base))[1] for p in xy])
    look = np.column_stack([nearest - xy, np.zeros(n)])
    heading, _ = heading_pitch(look)
    heights = np.arange(limits.min_z, top + layer_step * 0.5, layer_step)
    start = np.asarray(start, dtype=float)
    positions, shot, headings = [start], [False], [0.0]
    k0 = int(np.argmin(np.linalg.norm(xy - start[:2], axis=1)))
    for z in heights:
        order = (np.arange(n) + k0) % n
        positions.extend(np.column_stack([xy[order], np.full(n, z)]))
        shot.extend([True] * n)
        headings.extend(heading[order])
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
    security distance. Returns the photo positions (n, 3) in flight order."""
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
    return np.array(out).reshape(-1, 3), (90.0 if along_x else 0.0)


def scan_with_roof_grid(scene, camera, gsd: float, security: float, start, overlap: float = 0.7) -> Route:
    """The Structure Scan, then a nadir roof grid at the same overlaps: what surveyors fly when
    the roof matters. The grid is flown after the top layer, then back to the start."""
    scan = structure_scan(scene, camera, gsd, security, start, overlap, overlap)
    grid, lane_heading = roof_grid(scene, camera, gsd, security, overlap, overlap)
    pos = np.vstack([scan.positions[:-1], grid, scan.positions[-1:]])
    shot = np.concatenate([scan.shot[:-1], np.ones(len(grid), bool), [False]])
    heading = np.concatenate([scan.heading_deg[:-1], np.full(len(grid), lane_heading), [0.0]])
    pitch = np.concatenate([scan.pitch_deg[:-1], np.full(len(grid), -90.0), [0.0]])
    legs = ["initial"] + ["coverage"] * (len(pos) - 2) + ["final"]
    params = dict(scan.params, rule="structure-scan+roof-grid")
    route = Route(pos, shot, heading, pitch, legs, camera, params, frame=scene.frame)
    route.metrics = dict(scan.metrics, shots=int(shot.sum()), roof_grid_shots=int(len(grid)))
    return route
