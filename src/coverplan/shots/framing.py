"""How much of a photo a sample's face fills, and close views for the faces that fill little.

A photo's auto exposure meters its whole frame, and SfM finds its features in proportion to
the surface in it. A wide wall photographed at the standoff fills a third to a half of the
frame; a tower 4.4 m wide fills a fifth of it and the rest is sky or sunlit ground, so a tower
face in shade comes out dark and matches few features. Measured on the chapel under field
conditions (a field draw with the cells texture, sun from the south-east): the nave's
shaded north wall filled 25-50 % of its photos, was exposed at a mean grey of 80-90 and gave
15-20 keypoints per thousand pixels and 1,000-3,800 3D points per photo; the tower's shaded
west face above the nave filled 9-30 %, at grey 55, with 8-10 keypoints per thousand pixels and
200-570 points per photo, and 25 % of it had no 3D point within 0.2 m.

``frame_fill`` casts a coarse grid of rays through each camera's frame and sorts the target
surface they hit by the direction it faces. A view's *fill* of a sample is the share of its
frame on target surface facing within ``FACING_DEG`` of the sample's normal (surface that
faces the same way gets the same light). ``framed_view_matrix`` marks the views that fill at
least the sample's target: ``MIN_FILL``, or where no candidate reaches that (a spire's
triangular face), a share of the best fill any candidate gives.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from coverplan.geometry.orientation import camera_axes

FACING_DEG = 30.0
GRID = (24, 16)  # rays across and down the frame
N_BINS = 64  # directions surface normals are sorted into (a Fibonacci sphere, ~25 deg apart)
MIN_FILL = 0.25
BEST_SHARE = 0.8  # where no view reaches MIN_FILL: views within this share of the best count
# A framed view must also see its sample squarely enough for SIFT to match it with others: at 50
# deg a wall is foreshortened to 0.64 and its texture seen through pixels 1.6x wider.
FRAMED_INCIDENCE_DEG = 50.0
FRAMED_VIEWS_JUDGED = 2  # what the evaluator counts on routes that declare no framed-view rule
CLOSE_SHARE = 0.6  # close views: at this share of the standoff (never inside security + margin)
_CHUNK = 2048  # cameras per batch of rays (2048 x 384 rays, ~20 MB of directions)


def facing_bins(n: int = N_BINS) -> np.ndarray:
    """(n, 3) unit directions spread evenly over the sphere (a Fibonacci lattice).

    Parameters
    ----------
    n : int
        Directions.

    Returns
    -------
    (n, 3) float
        Unit vectors.
    """
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = np.pi * (1.0 + 5.0 ** 0.5) * k
    r = np.sqrt(1.0 - z * z)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def frame_fill(scene, positions, heading_deg, pitch_deg, camera, grid: tuple[int, int] = GRID) -> np.ndarray:
    """Share of each camera's frame on target surface, by the direction the surface faces.

    Parameters
    ----------
    scene : Scene
    positions : (n, 3) float
    heading_deg, pitch_deg : (n,) float
    camera : Camera
        Its field of view frames the rays.
    grid : (2,) int
        Rays across and down the frame.

    Returns
    -------
    (n, N_BINS) float32
        Per camera and ``facing_bins`` direction: the share of the frame's rays whose first
        hit is target surface facing nearest that direction (turned towards the camera).
    """
    positions = np.asarray(positions, dtype=float).reshape(-1, 3)
    n = len(positions)
    bins = facing_bins()
    out = np.zeros((n, len(bins)), dtype=np.float32)
    if n == 0:
        return out
    gx, gy = grid
    u = np.tan(np.radians(camera.hfov_deg) / 2) * ((np.arange(gx) + 0.5) / gx * 2 - 1)
    v = np.tan(np.radians(camera.vfov_deg) / 2) * ((np.arange(gy) + 0.5) / gy * 2 - 1)
    uu, vv = (a.ravel().astype(np.float32) for a in np.meshgrid(u, v))
    right, up, forward = (np.asarray(a, dtype=np.float32).reshape(-1, 3)
                          for a in camera_axes(np.asarray(heading_deg, float), np.asarray(pitch_deg, float)))
    # Every face's bin, seen from either side, looked up per hit (no per-hit search of the bins).
    faces = [np.asarray(m.face_normals, dtype=float) for m in scene.meshes]
    offset = np.concatenate([[0], np.cumsum([len(f) for f in faces])])
    normal = np.vstack(faces).astype(np.float32)
    out_bin, in_bin = (np.argmax(sign * normal @ bins.T, axis=1) for sign in (1.0, -1.0))
    target = np.zeros(len(scene.meshes), dtype=bool)
    target[list(scene.target_indices)] = True
    for lo in range(0, n, _CHUNK):
        hi = min(lo + _CHUNK, n)
        d = (forward[lo:hi, None] + uu[None, :, None] * right[lo:hi, None]
             - vv[None, :, None] * up[lo:hi, None]).reshape(-1, 3)
        o = np.repeat(positions[lo:hi], len(uu), axis=0)
        _dist, mesh, face = scene.rays.first_hit(o, d)
        # The ray caster holds the terrain's sheet after the scene's meshes: never target surface.
        hit = np.flatnonzero((mesh >= 0) & (mesh < len(scene.meshes)))
        hit = hit[target[mesh[hit]]]
        g = offset[mesh[hit]] + face[hit]
        outward = np.einsum("ij,ij->i", normal[g], d[hit]) < 0  # the side the camera sees
        b = np.where(outward, out_bin[g], in_bin[g])
        counts = np.bincount((hit // len(uu)) * len(bins) + b, minlength=(hi - lo) * len(bins))
        out[lo:hi] = counts.reshape(hi - lo, len(bins)) / len(uu)
    return out


def view_fill(fill: np.ndarray, cam: np.ndarray, pt: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Per (camera, sample) view: the share of the camera's frame on target surface facing
    within ``FACING_DEG`` of the sample's normal.

    Parameters
    ----------
    fill : (n_cameras, N_BINS) float
        ``frame_fill`` of the cameras.
    cam, pt : (m,) int
        The views: camera and sample indices.
    normals : (n_samples, 3) float

    Returns
    -------
    (m,) float
    """
    bins = facing_bins(fill.shape[1])
    near = (bins @ bins.T >= np.cos(np.radians(FACING_DEG))).astype(np.float32)
    own = np.argmax(np.asarray(normals, dtype=float) @ bins.T, axis=1)
    if len(cam) == 0:
        return np.zeros(0)
    used = np.unique(cam)
    smooth = np.asarray(fill[used], dtype=np.float32) @ near
    return smooth[np.searchsorted(used, cam), own[pt]].astype(float)


def fill_targets(pt: np.ndarray, fill: np.ndarray, n_samples: int, min_fill: float = MIN_FILL) -> np.ndarray:
    """Per sample: the fill a framed view must reach, ``min_fill`` or, where no view reaches
    it, ``BEST_SHARE`` of the best (inf for samples no view fills at all).

    Parameters
    ----------
    pt : (m,) int
        The sample of each view.
    fill : (m,) float
        The frame fill of each view.
    n_samples : int
        Samples.
    min_fill : float
        The fill asked.

    Returns
    -------
    (n_samples,) float
        The fill each sample's framed view must reach.
    """
    best = np.zeros(n_samples)
    np.maximum.at(best, pt, fill)
    return np.where(best > 0, np.minimum(min_fill, BEST_SHARE * best), np.inf)


def framed_view_matrix(cam: np.ndarray, pt: np.ndarray, fill: np.ndarray, incidence: np.ndarray, n_cands: int,
                       n_samples: int, targets: np.ndarray | None = None) -> sp.csr_matrix:
    """Candidates x samples, 1 where the view is framed: it fills at least the sample's
    target (``fill_targets`` of the views within ``FRAMED_INCIDENCE_DEG``) and sees the
    sample within ``FRAMED_INCIDENCE_DEG``.

    Parameters
    ----------
    cam, pt : (m,) int
        Candidate and sample of each view.
    fill : (m,) float
        Frame fill.
    incidence : (m,) float
        Degrees.
    n_cands, n_samples : int
        The matrix's shape.
    targets : (n_samples,) float, optional
        The fill per sample; ``fill_targets`` when None.

    Returns
    -------
    scipy.sparse.csr_matrix
        Candidates by samples.
    """
    square = incidence <= FRAMED_INCIDENCE_DEG
    if targets is None:
        targets = fill_targets(pt[square], fill[square], n_samples)
    ok = square & (fill >= targets[pt])
    return sp.csr_matrix((np.ones(int(ok.sum())), (cam[ok], pt[ok])), shape=(n_cands, n_samples))


def short_of_framing(cam: np.ndarray, pt: np.ndarray, fill: np.ndarray, incidence: np.ndarray, n_samples: int,
                     views: int) -> np.ndarray:
    """(n_samples,) bool: samples with fewer than ``views`` candidate views that fill
    ``MIN_FILL`` within ``FRAMED_INCIDENCE_DEG`` (and seen at all): the ones close views
    are made for.

    Parameters
    ----------
    cam, pt : (m,) int
        Candidate and sample of each view.
    fill : (m,) float
        Frame fill.
    incidence : (m,) float
        Degrees.
    n_samples : int
        Samples.
    views : int
        Framed views asked per sample.

    Returns
    -------
    (n_samples,) bool
        The samples short of them.
    """
    good = (fill >= MIN_FILL) & (incidence <= FRAMED_INCIDENCE_DEG)
    seen = np.bincount(pt, minlength=n_samples) > 0
    return seen & (np.bincount(pt[good], minlength=n_samples) < views)
