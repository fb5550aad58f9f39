"""Build the sample scenes in this folder (run: python meshes/make_meshes.py).

Sizes follow the thesis's experiments (Chapter 4): a 50 m grid with the building near its
centre, d_opt 7 m and security 3 m in mind. Targets and obstacles are separate files.
"""

from pathlib import Path

import numpy as np
import trimesh
from shapely.geometry import Polygon, box
from shapely.ops import unary_union

HERE = Path(__file__).resolve().parent
C = 25.0  # centre of the thesis's 50 m grid


def prism(polygon, height, z0=0.0):
    mesh = trimesh.creation.extrude_polygon(polygon, height)
    mesh.apply_translation([0, 0, z0])
    return mesh


def cuboid(x0, y0, z0, x1, y1, z1):
    return prism(box(x0, y0, x1, y1), z1 - z0, z0)


def union(*meshes):
    return trimesh.boolean.union(list(meshes), engine="manifold")


def save(mesh, name):
    mesh.export(HERE / name)
    print(f"{name}: {len(mesh.faces)} faces, watertight={mesh.is_watertight}, "
          f"bounds={np.round(mesh.bounds, 2).tolist()}")


def shapes_2d():
    """The four slice shapes of thesis Figure 4.1 (perimeters ~60, 80, 90, 60 m)."""
    square = box(C - 7.5, C - 7.5, C + 7.5, C + 7.5)
    ell = Polygon([(15, 15), (35, 15), (35, 25), (25, 25), (25, 35), (15, 35)])
    h_shape = unary_union([box(16, 17.25, 21, 32.75), box(29, 17.25, 34, 32.75), box(21, 23, 29, 27)])
    side = 20.0
    triangle = Polygon([(C - side / 2, C - side * np.sqrt(3) / 6),
                        (C + side / 2, C - side * np.sqrt(3) / 6),
                        (C, C + side * np.sqrt(3) / 3)])
    return {"square": square, "l": ell, "h": h_shape, "triangle": triangle}


def main():
    for name, poly in shapes_2d().items():
        print(f"  {name}: perimeter {poly.length:.1f} m")
        save(prism(poly, 8.0), f"{name}_prism.obj")

    core = cuboid(C - 6.5, C - 6.5, 0, C + 6.5, C + 6.5, 30)
    save(core, "thesis_prism.obj")
    ring = cuboid(C - 10.5, C - 10.5, 14, C + 10.5, C + 10.5, 16)
    save(union(core, ring), "ring_prism.obj")
    pyramid = trimesh.Trimesh(
        vertices=[[C - 12, C - 12, 0], [C + 12, C - 12, 0], [C + 12, C + 12, 0],
                  [C - 12, C + 12, 0], [C, C, 24]],
        faces=[[0, 2, 1], [0, 3, 2], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    save(pyramid, "pyramid.obj")
    # Figure 4.11: a large obstacle standing the full height and a small one floating between
    # the thesis's slices (at 5, 15, 25 m for its 10 m vertical coverage).
    large = cuboid(C + 14.5, C - 3, 0, C + 18.5, C + 3, 32)
    small = cuboid(C - 1.5, C - 12.5, 9, C + 1.5, C - 10.5, 11)
    save(trimesh.util.concatenate([large, small]), "fig411_obstacles.obj")

    walls = cuboid(C - 5, C - 4, 0, C + 5, C + 4, 6)
    roof = prism(Polygon([(-4, 0), (4, 0), (0, 3)]), 10.0)
    roof.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    roof.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    roof.apply_translation([0, 0, 0])
    roof.apply_translation(np.array([C, C, 6]) - [roof.bounds[:, 0].mean(), roof.bounds[:, 1].mean(), roof.bounds[0, 2]])
    save(union(walls, roof), "gabled_house.obj")

    yard = box(C - 15, C - 15, C + 15, C + 15).difference(box(C - 7, C - 7, C + 7, C + 7))
    save(prism(yard, 12.0), "courtyard.obj")

    # A box with an obstacle (a shed) flush against the middle of its south wall.
    save(cuboid(C - 8, C - 5, 0, C + 8, C + 5, 12), "flush_target.obj")
    save(cuboid(C - 3, C - 8, 0, C + 3, C - 5, 4), "flush_obstacle.obj")
    save(chapel(), "chapel.obj")
    save_footprints(HERE / "footprints.geojson")


def gable_roof(x0, y0, x1, y1, eaves, ridge):
    """A gabled roof over the box [x0, x1] x [y0, y1], its ridge along x at height ``ridge``."""
    half = (y1 - y0) / 2
    roof = prism(Polygon([(-half, 0), (half, 0), (0, ridge - eaves)]), x1 - x0)
    roof.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    roof.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    lo = roof.bounds[0]
    roof.apply_translation([x0 - lo[0], y0 - lo[1], eaves - lo[2]])
    return roof


def chapel():
    """A chapel: an 18 x 8 m nave (eaves 7 m, ridge 10 m) and at its west end a 4.5 m square
    tower of 24 m under a 6 m spire. The tower's faces are tall and narrow (4.5 x 24 m), the
    kind issue #31 found least rebuilt under field conditions."""
    nave = cuboid(C - 7, C - 4, 0, C + 11, C + 4, 7)
    roof = gable_roof(C - 7, C - 4, C + 11, C + 4, 7, 10)
    tower = cuboid(C - 11.5, C - 2.25, 0, C - 7, C + 2.25, 24)
    spire = trimesh.Trimesh(
        vertices=[[C - 11.5, C - 2.25, 24], [C - 7, C - 2.25, 24], [C - 7, C + 2.25, 24],
                  [C - 11.5, C + 2.25, 24], [C - 9.25, C, 30]],
        faces=[[0, 2, 1], [0, 3, 2], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    return union(nave, roof, tower, spire)


def save_footprints(path) -> None:
    """Four footprints drawn in metres around a street corner (Stuttgart), written in
    longitude/latitude (RFC 7946) with an eaves height and a ridge above it."""
    import json
    lon0, lat0 = 9.1829, 48.7758
    k_lon, k_lat = 111_200.0 * np.cos(np.radians(lat0)), 111_200.0
    shapes = {
        "house": (box(0, 0, 12, 8), 6.0, 3.0),
        "ell": (Polygon([(18, 0), (30, 0), (30, 10), (24, 10), (24, 5), (18, 5)]), 9.0, 0.0),
        "barn": (box(0, 16, 10, 30), 5.0, 4.0),
        "court": (box(16, 16, 36, 34).difference(box(22, 22, 30, 28)), 7.5, 0.0),
    }
    features = []
    for fid, (poly, height, ridge) in shapes.items():
        rings = [poly.exterior] + list(poly.interiors)
        coords = [[[round(lon0 + x / k_lon, 8), round(lat0 + y / k_lat, 8)] for x, y in ring.coords] for ring in rings]
        features.append({"type": "Feature", "id": fid, "properties": {"height": height, "ridge": ridge},
                         "geometry": {"type": "Polygon", "coordinates": coords}})
    Path(path).write_text(json.dumps({"type": "FeatureCollection", "features": features}, indent=1) + "\n")


if __name__ == "__main__":
    main()
