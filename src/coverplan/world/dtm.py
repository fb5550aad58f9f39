"""DTM rasters as terrain: read with rasterio over the box the plan needs, in the scene's CRS and local frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from coverplan.errors import InputFileError, ParameterError
from coverplan.world.terrain import MAX_CELLS, Terrain, fill_gaps

# Around the scene's meshes the terrain reaches this far (m): the flight and a distant start
# stay over it. Farther, the height of the grid's edge is used.
TERRAIN_MARGIN_M = 250.0


def read_dtm(path, scene_crs: str | None, origin, lo_xy, hi_xy, unit_m: float = 1.0) -> tuple[Terrain, list[str]]:
    """A DTM raster over the source-frame box [lo_xy, hi_xy] (grown by TERRAIN_MARGIN_M), in
    the scene's CRS and local frame (``origin`` subtracted), and notes on what was done.

    Parameters
    ----------
    path : str or Path
        A raster rasterio reads (GeoTIFF).
    scene_crs : str or None
        The scene's CRS; the raster is reprojected to it.
    origin : (3,) float
        The local frame's origin in the source frame.
    lo_xy, hi_xy : (2,) float
        The box needed, source frame.
    unit_m : float
        Metres per unit of the scene's coordinates.

    Returns
    -------
    terrain : Terrain
        In the local frame.
    notes : list of str
        What was done.
    """
    try:
        import rasterio
        from rasterio.enums import Resampling
        from rasterio.transform import from_origin
        from rasterio.warp import reproject, transform_bounds
    except ImportError:
        raise ParameterError("reading a DTM needs rasterio: pip install 'coverplan[terrain]'") from None
    path = Path(path)
    if not path.is_file():
        raise InputFileError(path, "does not exist")
    notes = []
    origin = np.asarray(origin, dtype=float)
    margin = TERRAIN_MARGIN_M / unit_m
    lo = np.asarray(lo_xy, dtype=float)[:2] - margin
    hi = np.asarray(hi_xy, dtype=float)[:2] + margin
    try:
        src = rasterio.open(path)
    except rasterio.errors.RasterioIOError as exc:
        raise InputFileError(path, f"is not a raster rasterio can read ({str(exc).splitlines()[0]})") from None
    with src:
        raster_crs = src.crs.to_string() if src.crs else None
        if raster_crs and not scene_crs:
            raise ParameterError(f"{path.name} is in {raster_crs} but the models carry no CRS; give theirs with --crs")
        res = float(min(abs(src.res[0]), abs(src.res[1])))
        if raster_crs and scene_crs and _same_crs(raster_crs, scene_crs):
            raster_crs = None  # same frame: read directly
        step = res if raster_crs is None else _step_in(scene_crs, raster_crs, res, lo, hi)
        # No grid beyond the raster: past the grid's edge its edge heights stand in anyway.
        have = np.array(src.bounds, dtype=float) if raster_crs is None else \
            np.array(transform_bounds(src.crs, scene_crs, *src.bounds), dtype=float)
        wanted_lo, wanted_hi = lo, hi
        lo, hi = np.maximum(lo, have[:2]), np.minimum(hi, have[2:])
        if (hi - lo < step).any():
            raise InputFileError(path, f"does not reach the scene: it covers x {have[0]:.1f}..{have[2]:.1f}, "
                                       f"y {have[1]:.1f}..{have[3]:.1f}; the scene is at x {wanted_lo[0] + margin:.1f}.."
                                       f"{wanted_hi[0] - margin:.1f}, y {wanted_lo[1] + margin:.1f}..{wanted_hi[1] - margin:.1f}")
        cells = np.prod(np.ceil((hi - lo) / step) + 1)
        resampling = Resampling.bilinear
        if raster_crs is None and cells <= MAX_CELLS and abs(src.res[0] - src.res[1]) < 1e-9 * res:
            # Nodes on the raster's pixel centres take its heights as they are; nodes on its
            # corners took the mean of four pixels, lowering a hilltop or the top of a bank.
            first, last = have[:2] + res / 2, have[2:] - res / 2
            lo = np.clip(first + np.floor((lo - first) / res) * res, first, last)
            hi = np.clip(first + np.ceil((hi - first) / res) * res, first, last)
        if cells > MAX_CELLS:
            step *= float(np.sqrt(cells / MAX_CELLS))
            resampling = Resampling.max
            notes.append(f"{path.name}: resampled to {step * unit_m:.2f} m cells, keeping each cell's highest ground")
        nx = int(np.ceil((hi[0] - lo[0]) / step)) + 1
        ny = int(np.ceil((hi[1] - lo[1]) / step)) + 1
        out = np.full((ny, nx), np.nan, dtype=np.float64)
        # Node (i, j) of our grid is a cell centre of the destination raster; its rows run north
        # to south, ours south to north.
        transform = from_origin(lo[0] - step / 2, lo[1] + (ny - 0.5) * step, step, step)
        # Same frame (or none given): the same CRS on both sides makes the warp a pure resampling.
        src_crs = src.crs or "EPSG:3857"
        dst_crs = scene_crs if raster_crs else src_crs
        reproject(rasterio.band(src, 1), out, src_crs=src_crs, dst_transform=transform, dst_crs=dst_crs,
                  src_nodata=src.nodata, dst_nodata=np.nan, resampling=resampling)
    heights = out[::-1]
    valid = np.isfinite(heights)
    if not valid.any():
        raise InputFileError(path, f"has no height over the scene (its area does not reach the target at "
                                   f"{', '.join(f'{v:.1f}' for v in (lo + hi) / 2)})")
    share = float(valid.mean()) * float(np.prod(hi - lo) / np.prod(wanted_hi - wanted_lo))
    if share < 0.99:
        notes.append(f"{path.name} covers {share:.0%} of the area within {TERRAIN_MARGIN_M:g} m of the scene; "
                     "beyond it the nearest height stands in")
    # Heights in the CRS's unit like the models' (scaled with them), then the local frame.
    heights = fill_gaps(heights, str(path)) * unit_m - origin[2]
    x0, y0 = lo[0] * unit_m - origin[0], lo[1] * unit_m - origin[1]
    return Terrain(x0, y0, step * unit_m, step * unit_m, heights, path.name), notes


def _same_crs(a: str, b: str) -> bool:
    from pyproj import CRS
    try:
        return CRS.from_user_input(a).equals(CRS.from_user_input(b), ignore_axis_order=True)
    except Exception:
        return a == b


def _step_in(scene_crs: str, raster_crs: str, res: float, lo, hi) -> float:
    """The raster's cell size expressed in the scene CRS's units (near the scene)."""
    from pyproj import Transformer
    t = Transformer.from_crs(scene_crs, raster_crs, always_xy=True)
    c = (np.asarray(lo) + np.asarray(hi)) / 2.0
    x, y = t.transform([c[0], c[0] + 1.0, c[0]], [c[1], c[1], c[1] + 1.0])
    per_unit = float(np.mean([np.hypot(x[1] - x[0], y[1] - y[0]), np.hypot(x[2] - x[0], y[2] - y[0])]))
    return res / max(per_unit, 1e-12)
