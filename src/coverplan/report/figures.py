"""PNG figures with matplotlib: overview (top and side), per-slice views, coverage histograms."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import shapely  # noqa: E402
from matplotlib.collections import LineCollection, PolyCollection  # noqa: E402

from coverplan.evaluation import evaluate
from coverplan.report.frame import focus_bounds  # noqa: E402
from coverplan.world.zones import KEEP_OUT, Zones  # noqa: E402

LEG_COLOURS = {"initial": "#2b6cb0", "coverage": "#dd6b20", "final": "#805ad5"}
ROLE_COLOURS = {"target": "#a0aec0", "obstacle": "#c53030"}
ZONE_COLOURS = {"keep-out": "#e53e3e", "keep-in": "#2f855a"}


def _segment_legs(route) -> list[str]:
    legs = route.leg
    return ["initial" if legs[i] == "initial" else "final" if legs[i + 1] == "final" else "coverage"
            for i in range(len(legs) - 1)]


def _projected_meshes(ax, scene, axes: tuple[int, int]):
    for part in scene.parts:
        tri = part.mesh.triangles[:, :, list(axes)]
        if len(tri) > 60_000:
            tri = tri[np.random.default_rng(0).choice(len(tri), 60_000, replace=False)]
        ax.add_collection(PolyCollection(tri, facecolors=ROLE_COLOURS[part.role], edgecolors="none",
                                         alpha=0.35 if part.role == "target" else 0.6))


def _zones(ax, route, lo, hi):
    """The route's zones in plan view: keep-out filled red, keep-in outlined green, each
    named inside the part of it within the view [lo, hi]."""
    view = shapely.box(lo[0], lo[1], hi[0], hi[1])
    for zone in Zones.from_list(route.params.get("zones")).zones:
        colour = ZONE_COLOURS[zone.kind]
        for poly in getattr(zone.polygon, "geoms", [zone.polygon]):
            for ring in [poly.exterior, *poly.interiors]:
                xy = np.asarray(ring.coords)[:, :2]
                ax.fill(xy[:, 0], xy[:, 1], facecolor=colour if zone.kind == KEEP_OUT else "none",
                        alpha=0.25 if zone.kind == KEEP_OUT else 1.0, edgecolor=colour, lw=1.5,
                        hatch="//" if zone.kind == KEEP_OUT else None)
            seen = poly.intersection(view) if zone.kind == KEEP_OUT else poly.exterior.intersection(view)
            if not seen.is_empty:
                c = seen.representative_point() if zone.kind == KEEP_OUT else seen.interpolate(0.5, normalized=True)
                ax.annotate(zone.name, (c.x, c.y), color=colour, fontsize=9, ha="center", va="center")


def _path(ax, route, axes: tuple[int, int], mask=None):
    p = route.positions[:, list(axes)]
    seg = np.stack([p[:-1], p[1:]], axis=1)
    legs = _segment_legs(route)
    keep = np.ones(len(seg), bool) if mask is None else mask
    ax.add_collection(LineCollection(seg[keep], colors=[LEG_COLOURS[legs[i]] for i in np.flatnonzero(keep)],
                                     linewidths=1.0))
    if mask is None:
        ax.scatter(p[route.shot, 0], p[route.shot, 1], s=8, c="#1a202c", zorder=3, label="shots")
        ax.scatter([p[0, 0]], [p[0, 1]], s=80, marker="*", c="#38a169", zorder=4, label="start")


def overview(route, scene, path) -> Path:
    """Draw the scene, its zones, the flight path and the photos from above and from the south.

    Parameters
    ----------
    route : Route
        The route drawn.
    scene : Scene
        Its scene.
    path : str or Path
        The PNG file.

    Returns
    -------
    Path
        ``path``.
    """
    fig, (top, side) = plt.subplots(1, 2, figsize=(13, 5.8), gridspec_kw={"width_ratios": [1, 1.3]})
    lo, hi = focus_bounds(route, scene)
    for ax, axes, title, labels in ((top, (0, 1), "top view", ("x (east) m", "y (north) m")),
                                    (side, (0, 2), "side view (from the south)", ("x (east) m", "z m"))):
        _projected_meshes(ax, scene, axes)
        if axes == (0, 1):
            _zones(ax, route, lo, hi)
        _path(ax, route, axes)
        ax.set_title(title)
        ax.set_xlabel(labels[0])
        ax.set_ylabel(labels[1])
        ax.set_aspect("equal")
        ax.set_xlim(lo[axes[0]], hi[axes[0]])
        ax.set_ylim(lo[axes[1]], hi[axes[1]])
    handles = [plt.Line2D([], [], color=c, label=f"{k} path") for k, c in LEG_COLOURS.items()]
    handles += [plt.Line2D([], [], marker="o", ls="", color="#1a202c", label="shot"),
                plt.Line2D([], [], marker="*", ls="", color="#38a169", markersize=10, label="start")]
    handles += [matplotlib.patches.Patch(color=c, alpha=0.6, label=r) for r, c in ROLE_COLOURS.items()]
    kinds = {z["kind"] for z in route.params.get("zones") or []}
    handles += [matplotlib.patches.Patch(facecolor=ZONE_COLOURS[k], alpha=0.3, edgecolor=ZONE_COLOURS[k],
                                         label=f"{k} zone") for k in sorted(kinds)]
    side.legend(handles=handles, loc="upper right", fontsize=8)
    m = route.metrics or {}
    fig.suptitle(f"{int(route.shot.sum())} shots, {route.path_length:,.0f} m flight"
                 + (f", planned in {m['planning_time_s']:.1f} s" if m.get("planning_time_s") else ""))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def slices(route, scene, path, max_levels: int = 6) -> Path:
    """Horizontal slices at the heights shots cluster at, as in the thesis's Figures 4.2-4.4.

    Parameters
    ----------
    route : Route
        The route drawn.
    scene : Scene
        Its scene, cut at each level.
    path : str or Path
        The PNG file.
    max_levels : int
        The most slices drawn.

    Returns
    -------
    Path
        ``path``.
    """
    shots = route.shots
    z = route.positions[shots, 2]
    band = max(route.camera.footprint(route.d_opt * 0.7)[1] * 0.5, 1e-3)
    levels = np.unique(np.round(z / band) * band)
    if len(levels) > max_levels:
        levels = levels[np.linspace(0, len(levels) - 1, max_levels).round().astype(int)]
    cols = min(3, len(levels))
    rows = int(np.ceil(len(levels) / cols))
    fig, axs = plt.subplots(rows, cols, figsize=(4.6 * cols, 4.4 * rows), squeeze=False)
    lo, hi = focus_bounds(route, scene)
    for ax, level in zip(axs.ravel(), levels):
        for part in scene.parts:  # everything the band cuts: sections at its bottom, middle and top
            for zc in (level - band / 2 + 1e-3, level, level + band / 2 - 1e-3):
                sec = part.mesh.section(plane_origin=[0, 0, zc], plane_normal=[0, 0, 1])
                for line in ([] if sec is None else sec.discrete):
                    ax.fill(line[:, 0], line[:, 1], color=ROLE_COLOURS[part.role], alpha=0.35, lw=0)
        near = np.abs(route.positions[:, 2] - level) <= band / 2
        seg = near[:-1] & near[1:]
        _path(ax, route, (0, 1), mask=seg)
        sel = shots[np.abs(z - level) <= band / 2]
        ax.scatter(route.positions[sel, 0], route.positions[sel, 1], s=10, c="#1a202c", zorder=3)
        h = np.radians(route.heading_deg[sel])
        length = route.d_opt * 0.25
        ax.quiver(route.positions[sel, 0], route.positions[sel, 1], np.sin(h) * length, np.cos(h) * length,
                  angles="xy", scale_units="xy", scale=1, width=0.004, color="#2d3748")
        ax.set_title(f"z ≈ {level:.1f} m: {len(sel)} shots")
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal")
    for ax in axs.ravel()[len(levels):]:
        ax.axis("off")
    fig.suptitle("shots by height band (arrows: heading; target grey, obstacles red)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return Path(path)


def coverage_histogram(evaluation, path) -> Path:
    """Draw how many photos see each sample of the surface.

    Parameters
    ----------
    evaluation : Evaluation
        The evaluator's verdict.
    path : str or Path
        The PNG file.

    Returns
    -------
    Path
        ``path``.
    """
    m = evaluation.metrics
    reach = evaluation.reachable
    views = evaluation.views[reach]
    area = evaluation.samples.area[reach]
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
    top = int(max(views.max(initial=0), 4))
    a.bar(np.arange(top + 1), np.bincount(views, weights=area, minlength=top + 1),
          color=["#e53e3e", "#ed8936"] + ["#2f855a"] * (top - 1))
    a.set_xlabel("valid views of a surface point (nt-imaged)")
    a.set_ylabel("surface area m²")
    a.set_title(f"coverage {m['coverage_pct']:.2f} % of the reachable surface, {m['p_outliers']} p-outliers")
    d = evaluation.pairs[2]
    b.hist(d, bins=40, color="#2b6cb0")
    b.axvline(evaluation.route.d_opt, color="#c53030", ls="--", label=f"d_opt {evaluation.route.d_opt:.1f} m")
    b.set_xlabel("range camera to point (d-image) m")
    b.set_ylabel("views")
    b.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def reconstruction(route, points, recovered, simulation, path) -> Path:
    """What SfM recovered: surface points green (a 3D point within 0.2 m) or red, and the
    photos registered (black) or lost (red), seen from two sides.

    Parameters
    ----------
    route : Route
        The route flown.
    points : (n, 3) float
        Samples of the target surface.
    recovered : (n,) bool
        Which samples have a 3D point within 0.2 m.
    simulation : Simulation
        Gives which photos were registered.
    path : str or Path
        The PNG file.

    Returns
    -------
    Path
        ``path``.
    """
    fig = plt.figure(figsize=(13, 6))
    shots = route.positions[route.shots]
    reg = simulation.shot_registered.astype(bool)
    for k, azim in enumerate((-60, 120)):
        ax = fig.add_subplot(1, 2, k + 1, projection="3d")
        ax.scatter(*points[~recovered].T, s=2, c="#e53e3e", depthshade=False, label="not recovered")
        ax.scatter(*points[recovered].T, s=2, c="#38a169", depthshade=False, label="recovered @0.2 m")
        ax.scatter(*shots[reg].T, s=10, c="#1a202c", label="photo registered")
        if (~reg).any():
            ax.scatter(*shots[~reg].T, s=24, c="#e53e3e", marker="x", label="photo lost")
        ax.view_init(elev=25, azim=azim)
        ax.set_box_aspect(np.ptp(np.vstack([points, shots]), axis=0) + 1e-6)
        ax.set_xlabel("x m")
        ax.set_ylabel("y m")
        ax.set_zlabel("z m")
        if k == 0:
            ax.legend(loc="upper left", fontsize=8, markerscale=3)
    fig.suptitle(f"COLMAP: {simulation.registered} of {simulation.photos} photos in the largest of "
                 f"{simulation.models} model(s), {simulation.reconstructed_pct:.1f} % of the surface within 0.2 m")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return Path(path)


def write_figures(route, scene, prefix, evaluation=None, simulation=None) -> list[Path]:
    """Write ``PREFIX_overview.png``, ``PREFIX_slices.png`` and ``PREFIX_coverage.png``, and
    with a simulation ``PREFIX_reconstruction.png``.

    Parameters
    ----------
    route : Route
        The route drawn.
    scene : Scene
        Its scene.
    prefix : str or Path
        The start of each file's path.
    evaluation : Evaluation, optional
        Evaluated here when None.
    simulation : Simulation, optional
        Adds the reconstruction figure.

    Returns
    -------
    list of Path
        The files written.
    """
    if evaluation is None:
        evaluation = evaluate(route, scene)
    prefix = str(prefix)
    out = [overview(route, scene, f"{prefix}_overview.png"), slices(route, scene, f"{prefix}_slices.png"),
           coverage_histogram(evaluation, f"{prefix}_coverage.png")]
    if simulation is not None:
        pts = evaluation.samples.points
        out.append(reconstruction(route, pts, simulation.reconstructed_at(pts), simulation,
                                  f"{prefix}_reconstruction.png"))
    return out
