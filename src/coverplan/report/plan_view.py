"""The report's map: the flight seen from above, each battery flight in its colour, the
target, obstacles and zones, the take-off point, north and a scale bar, as an inline SVG."""

from __future__ import annotations

import html

import numpy as np
import shapely

from coverplan.geometry.geo import grid_convergence, has_georeference
from coverplan.report.frame import display_mesh, focus_bounds
from coverplan.world.zones import KEEP_OUT, Zones

FLIGHT_COLOURS = ("#dd6b20", "#2b6cb0", "#2f855a", "#b83280", "#805ad5", "#c05621", "#2c7a7b", "#975a16")
MAX_OUTLINE_FACES = 20_000


def flight_colour(k: int) -> str:
    """The colour of battery flight ``k`` (1-based), the same in the map, the 3D view and the table.

    Parameters
    ----------
    k : int
        The flight's number, from 1.

    Returns
    -------
    str
        A CSS colour.
    """
    return FLIGHT_COLOURS[(k - 1) % len(FLIGHT_COLOURS)]


def footprint(mesh, max_faces: int = MAX_OUTLINE_FACES):
    """The mesh seen from above: the union of its triangles projected on the ground plane.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        The mesh.
    max_faces : int
        Larger meshes are simplified first.

    Returns
    -------
    shapely.Polygon or shapely.MultiPolygon
        The outline in x, y.
    """
    vertices, faces = display_mesh(mesh, max_faces)
    tri = vertices[faces][:, :, :2]
    cross = (tri[:, 1, 0] - tri[:, 0, 0]) * (tri[:, 2, 1] - tri[:, 0, 1]) \
        - (tri[:, 1, 1] - tri[:, 0, 1]) * (tri[:, 2, 0] - tri[:, 0, 0])
    tri = tri[np.abs(cross) > 1e-9]  # walls seen edge-on
    if not len(tri):
        return shapely.Polygon()
    rings = np.concatenate([tri, tri[:, :1]], axis=1)
    return shapely.union_all(shapely.polygons(rings)).buffer(0)


def north_direction(route) -> tuple[np.ndarray, str]:
    """True north as a unit (x, y) of the local frame at the take-off point, and its label.

    Parameters
    ----------
    route : Route
        Its georeference gives the grid's rotation from north.

    Returns
    -------
    direction : (2,) float
        True north in the local frame.
    label : str
        ``"N"``, or what the direction is without a georeference.
    """
    if not has_georeference(route.frame):
        return np.array([0.0, 1.0]), "+y (no georeference)"
    gamma = np.radians(float(grid_convergence(route.frame, route.positions[:1])[0]))
    return np.array([-np.sin(gamma), np.cos(gamma)]), "N"


def scale_length(span_m: float) -> float:
    """A round length (1, 2 or 5 times a power of ten) near a quarter of ``span_m``.

    Parameters
    ----------
    span_m : float
        The width of the picture in metres.

    Returns
    -------
    float
        The scale bar's length in metres.
    """
    target = max(span_m / 4.0, 1e-3)
    power = 10.0 ** np.floor(np.log10(target))
    return float(max(m * power for m in (1.0, 2.0, 5.0) if m * power <= target))


def plan_view_svg(route, scene, width_px: int = 640) -> str:
    """The flight from above as an SVG element (x east or the model's x, y up the page).

    Parameters
    ----------
    route : Route
    scene : Scene
    width_px : int
        Width of the drawing; its height follows the framed area.

    Returns
    -------
    str
        ``<svg>`` with ``data-*`` attributes a test can read: ``data-flights`` (count),
        ``data-scale-m`` (the scale bar's length) and ``data-north`` (the arrow's x, y).
    """
    lo, hi = focus_bounds(route, scene)
    span = np.maximum(hi[:2] - lo[:2], 1.0)
    margin = 28.0
    scale = (width_px - 2 * margin) / span[0]
    height_px = int(span[1] * scale + 2 * margin)

    def xy(points) -> np.ndarray:
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        return np.column_stack([margin + (p[:, 0] - lo[0]) * scale, height_px - margin - (p[:, 1] - lo[1]) * scale])

    def path(points) -> str:
        return " ".join(f"{x:.1f},{y:.1f}" for x, y in xy(points))

    def shapes(geometry, cls: str) -> list[str]:
        out = []
        for poly in getattr(geometry, "geoms", [geometry]):
            if poly.is_empty or poly.geom_type != "Polygon":
                continue
            d = " ".join("M " + path(np.asarray(ring.coords)[:, :2]) + " Z"
                         for ring in [poly.exterior, *poly.interiors])
            out.append(f'<path class="{cls}" d="{d}" fill-rule="evenodd"/>')
        return out

    frame = shapely.box(lo[0], lo[1], hi[0], hi[1])
    items = []
    for part in scene.parts:
        outline = footprint(part.mesh).intersection(frame)
        items += shapes(outline, "target" if part.role == "target" else "obstacle")
    for zone in Zones.from_list(route.params.get("zones")).zones:
        items += shapes(zone.polygon.intersection(frame), "keep-out" if zone.kind == KEEP_OUT else "keep-in")
    for k, rows in enumerate(route.flight_rows(), start=1):
        colour = flight_colour(k)
        items.append(f'<polyline class="flight" data-flight="{k}" points="{path(route.positions[rows, :2])}" '
                     f'fill="none" stroke="{colour}" stroke-width="1.6"/>')
        shots = rows[route.shot[rows]]
        items += [f'<circle cx="{x:.1f}" cy="{y:.1f}" r="1.8" fill="{colour}"/>' for x, y in xy(route.positions[shots, :2])]
    tx, ty = xy(route.positions[:1, :2])[0]
    items.append(f'<g class="takeoff"><circle cx="{tx:.1f}" cy="{ty:.1f}" r="7" fill="#fff" stroke="#1a202c" '
                 f'stroke-width="2"/><text x="{tx:.1f}" y="{ty + 4:.1f}" text-anchor="middle" font-size="10" '
                 'font-weight="bold">H</text></g>')
    north, label = north_direction(route)
    nx, ny = width_px - margin - 6, margin + 22
    tip = (nx + 18 * north[0], ny - 18 * north[1])
    tail = (nx - 14 * north[0], ny + 14 * north[1])
    items.append(f'<g class="north"><line x1="{tail[0]:.1f}" y1="{tail[1]:.1f}" x2="{tip[0]:.1f}" y2="{tip[1]:.1f}" '
                 'stroke="#1a202c" stroke-width="2" marker-end="url(#arrow)"/>'
                 f'<text x="{tip[0] + 6 * north[0]:.1f}" y="{tip[1] - 6 * north[1] - 2:.1f}" text-anchor="middle" '
                 f'font-size="11">{html.escape(label)}</text></g>')
    length = scale_length(span[0])
    bar = length * scale
    bx, by = margin, height_px - 10
    items.append(f'<g class="scale"><line x1="{bx:.1f}" y1="{by:.1f}" x2="{bx + bar:.1f}" y2="{by:.1f}" '
                 f'stroke="#1a202c" stroke-width="3"/><text x="{bx + bar + 6:.1f}" y="{by + 4:.1f}" '
                 f'font-size="11">{length:g} m</text></g>')
    return (f'<svg class="plan-view" xmlns="http://www.w3.org/2000/svg" width="{width_px}" height="{height_px}" '
            f'viewBox="0 0 {width_px} {height_px}" data-flights="{route.n_flights}" data-scale-m="{length:g}" '
            f'data-scale-px="{bar:.2f}" data-north="{north[0]:.4f},{north[1]:.4f}">'
            '<defs><marker id="arrow" viewBox="0 0 10 10" refX="5" refY="5" markerWidth="6" markerHeight="6" '
            'orient="auto-start-reverse"><path d="M 0 0 L 10 5 L 0 10 z"/></marker></defs>'
            '<style>.target{fill:#cbd5e0;stroke:#4a5568}.obstacle{fill:#e2e8f0;stroke:#a0aec0}'
            '.keep-out{fill:#e53e3e;fill-opacity:.15;stroke:#c53030;stroke-dasharray:4 3}'
            '.keep-in{fill:none;stroke:#2f855a;stroke-width:2;stroke-dasharray:6 3}</style>'
            + "".join(items) + "</svg>")
