"""The materials of field photos: textures filtered by how much surface a pixel spans.

Octaves run from millimetres to metres, each faded out where a pixel's footprint on the surface
is too wide to show it, so a far or grazing photo sees a plainer wall, as a real one does. Two
families differ in their statistics: ``noise`` (smooth value noise) and ``cells`` (cellular
stone: flat tones with sharp joints). Real façades (``harsh``) add plaster or brick courses, a
regular grid of identical windows and roofs of repeated tiles.
"""

from __future__ import annotations

import numpy as np

from coverplan.sfm.render import _PRIMES, value_noise

FINEST_M = 0.004  # plaster grain, sand, stone pores


COARSEST_M = 4.0  # stains, weathering, patches


def pixel_footprint(distance: np.ndarray, cos_incidence: np.ndarray, fx: float) -> np.ndarray:
    """(n,) metres of surface one pixel spans along its longer side.

    Parameters
    ----------
    distance : (n,) float
        Metres.
    cos_incidence : (n,) float
        Cosine of the incidence.
    fx : float
        Focal length, px.

    Returns
    -------
    (n,) float
        Metres.
    """
    return distance / fx / np.maximum(np.abs(cos_incidence), 0.2)


def _fade(scale_m, footprint) -> np.ndarray:
    """Contrast kept of a pattern of ``scale_m`` seen through pixels of ``footprint`` metres:
    all of it from 2 px per period, none under 1 px (it averages out instead of aliasing)."""
    return np.clip(np.asarray(scale_m, dtype=np.float32) / footprint - 1.0, 0.0, 1.0).astype(np.float32)


def physical_noise(points: np.ndarray, footprint: np.ndarray, lattice: np.ndarray) -> np.ndarray:
    """Value noise with equal energy per octave from FINEST_M to COARSEST_M, filtered by footprint.

    Parameters
    ----------
    points : (n, 3) float
        Surface points.
    footprint : (n,) float
        Metres per pixel there.
    lattice : (m,) float32
        ``noise_lattice``'s values.

    Returns
    -------
    (n,) float
        Albedo.
    """
    n_oct = int(round(np.log2(COARSEST_M / FINEST_M))) + 1
    total = np.zeros(len(points), dtype=np.float32)
    for k in range(n_oct):
        cell = FINEST_M * 2.0 ** k
        w = _fade(cell, footprint)
        live = np.flatnonzero(w > 0)
        if len(live):
            total[live] += w[live] * (value_noise(points[live], cell, lattice, 53 * k + 5) - 0.5)
    # Seven visible octaves (a photo at a usual standoff) have about the ideal texture's contrast.
    return np.clip(0.5 + total * 0.55, 0.0, 1.0)


def _cell_hash(i: np.ndarray, salt: int) -> np.ndarray:
    """A uint32 hash per integer 3D cell (n, 3)."""
    u = i.astype(np.uint32)
    h = (u[:, 0] * _PRIMES[0]) ^ (u[:, 1] * _PRIMES[1]) ^ (u[:, 2] * _PRIMES[2]) ^ np.uint32(salt * 0x9E3779B1 & 0xFFFFFFFF)
    h = h * np.uint32(0x5BD1E995)
    return h ^ (h >> np.uint32(15))


def cellular(points: np.ndarray, size: float, salt: int):
    """Worley cells of about ``size`` metres: (tone in [0, 1] of the nearest cell, metres to the
    joint with the next cell, doubled). Feature points are searched in the 2 x 2 x 2 cells
    nearest the point, which finds the nearest one nearly always at an eighth of the work.

    Parameters
    ----------
    points : (n, 3) float
        Surface points.
    size : float
        Metres.
    salt : int
        The hash's salt.

    Returns
    -------
    tone : (n,) float
        The nearest cell's tone.
    gap : (n,) float
        Metres to the joint, doubled.
    """
    p = (points / size).astype(np.float32)
    base = np.floor(p)
    near = np.where(p - base < 0.5, -1, 0).astype(np.int64) + base.astype(np.int64)
    best = np.full(len(p), np.inf, dtype=np.float32)
    second = np.full(len(p), np.inf, dtype=np.float32)
    tone = np.zeros(len(p), dtype=np.float32)
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):
                c = near + np.array([dx, dy, dz])
                h = _cell_hash(c, salt)
                d = np.zeros(len(p), dtype=np.float32)
                for a, shift in enumerate((0, 10, 20)):
                    e = c[:, a] + ((h >> np.uint32(shift)) & np.uint32(0x3FF)).astype(np.float32) / 1024.0 - p[:, a]
                    d += e * e
                closer = d < best
                np.copyto(second, np.where(closer, best, np.minimum(second, d)))
                np.copyto(tone, ((h >> np.uint32(7)) & np.uint32(0xFF)).astype(np.float32) / 255.0, where=closer)
                np.copyto(best, d, where=closer)
    gap = (np.sqrt(second) - np.sqrt(best)) * size
    return tone, gap


def physical_cells(points: np.ndarray, footprint: np.ndarray) -> np.ndarray:
    """Cellular stone: blocks of two sizes with their own tones and dark joints, filtered.

    Parameters
    ----------
    points : (n, 3) float
        Surface points.
    footprint : (n,) float
        Metres per pixel there.

    Returns
    -------
    (n,) float
        Albedo.
    """
    out = np.full(len(points), 0.5, dtype=np.float32)
    for size, amp, salt in ((0.45, 0.5, 3), (0.09, 0.35, 5), (0.02, 0.25, 7)):
        w = _fade(size, footprint)
        live = np.flatnonzero(w > 0)
        if not len(live):
            continue
        tone, gap = cellular(points[live], size, salt)
        joint = np.clip(1.0 - gap / (0.08 * size), 0.0, 1.0)  # joints about 4 % of a block
        wj = _fade(0.08 * size, footprint[live])
        out[live] += w[live] * amp * (tone - 0.5) - wj * 0.45 * amp * joint
    return np.clip(out, 0.0, 1.0)


def _filtered_pulse(x: np.ndarray, period: float, width: float, footprint: np.ndarray) -> np.ndarray:
    """Share of a box of ``footprint`` around x covered by lines ``width`` wide every ``period``."""
    def integral(y):
        return np.floor(y / period) * width + np.minimum(np.mod(y, period), width)
    f = np.maximum(footprint, 1e-6)
    return (integral(x + 0.5 * f) - integral(x - 0.5 * f)) / f


def facade_coordinates(points: np.ndarray, normals: np.ndarray, ground_z: float):
    """(along, up): metres along a wall (horizontal, perpendicular to its normal) and above ground.

    Parameters
    ----------
    points, normals : (n, 3) float
        Wall points.
    ground_z : float
        Metres.

    Returns
    -------
    along, up : (n,) float
        Metres.
    """
    t = np.column_stack([-normals[:, 1], normals[:, 0]])
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-9)
    return np.einsum("ij,ij->i", points[:, :2], t), points[:, 2] - ground_z


def brick(along, up, footprint, salt: int) -> np.ndarray:
    """Courses of 7.1 cm (6.1 cm bricks, 1 cm joints), bricks 24 cm long in stretcher bond,
    one tone per brick.

    Parameters
    ----------
    along, up : (n,) float
        ``facade_coordinates``.
    footprint : (n,) float
        Metres per pixel there.
    salt : int
        The tones' salt.

    Returns
    -------
    (n,) float
        Albedo.
    """
    course, length, joint = 0.071, 0.24, 0.01
    row = np.floor(up / course)
    shifted = along + 0.5 * length * (row % 2)
    ids = np.column_stack([np.floor(shifted / length), row, np.zeros_like(row)]).astype(np.int64)
    tone = ((_cell_hash(ids, salt) >> 9) & 0xFF) / 255.0
    mortar = np.maximum(_filtered_pulse(up, course, joint, footprint),
                        _filtered_pulse(shifted, length, joint, footprint))
    value = 0.5 + 0.3 * _fade(course, footprint) * (tone - 0.5)
    return value * (1.0 - mortar) + 0.82 * mortar


WINDOW_BAY_M, STOREY_M = 2.6, 3.0


WINDOW_W, WINDOW_H, SILL_M, FRAME_M = 1.2, 1.4, 0.9, 0.07


def windows(along, up):
    """(glass, frame) masks of a regular grid of identical windows, storey by storey.

    Parameters
    ----------
    along, up : (n,) float
        ``facade_coordinates``.

    Returns
    -------
    glass, frame : (n,) bool
        Masks.
    """
    a = np.mod(along, WINDOW_BAY_M) - 0.5 * (WINDOW_BAY_M - WINDOW_W)
    b = np.mod(up, STOREY_M) - SILL_M
    inside = (a >= 0) & (a <= WINDOW_W) & (b >= 0) & (b <= WINDOW_H) & (up > SILL_M)
    border = np.minimum(np.minimum(a, WINDOW_W - a), np.minimum(b, WINDOW_H - b))
    frame = inside & (border < FRAME_M)
    return inside & ~frame, frame


def tiles(points, normals, footprint) -> np.ndarray:
    """Roof tiles in rows 33 cm apart down the slope, 22 cm wide, each shaded alike.

    Parameters
    ----------
    points, normals : (n, 3) float
        Roof points.
    footprint : (n,) float
        Metres per pixel there.

    Returns
    -------
    (n,) float
        Albedo.
    """
    h = normals[:, :2]
    hn = np.linalg.norm(h, axis=1, keepdims=True)
    down = np.where(hn > 0.05, h / np.maximum(hn, 1e-9), [[0.0, 1.0]])
    across = np.column_stack([-down[:, 1], down[:, 0]])
    s = np.einsum("ij,ij->i", points[:, :2], down)
    u = np.einsum("ij,ij->i", points[:, :2], across)
    pitch, width = 0.33, 0.22
    row = np.floor(s / pitch)
    f = np.mod(s, pitch) / pitch
    shown = _fade(pitch, footprint)
    gradient = 0.35 + 0.45 * f * shown  # each tile darkens under the one above
    seam = _filtered_pulse(u + 0.5 * width * (row % 2), width, 0.012, footprint)
    return np.where(shown > 0, gradient * (1.0 - 0.6 * seam), 0.55)
