"""What Structure-from-Motion needs of a set of shots, beyond "two views 5 deg apart".

Measured with ``coverplan simulate`` (docs/design.md, docs/reconstruction.md): photos more than
~40 deg apart rarely match, surface seen by only two photos is seldom reconstructed, and a
set of photos whose "easy" pairs do not chain together falls apart into several models. So:

- every surface sample needs ``min_views`` views with one pair whose rays meet at an angle in
  [min_triangulation_deg, max_pair_deg] (wide enough to triangulate, narrow enough to match);
- two shots are *linked* (SfM will match them) when each images a good part of what the
  other images (``min_overlap`` of the smaller footprint, counted on surface samples) and
  their rays to the shared surface meet at most ``max_pair_deg`` apart;
- every shot needs ``min_neighbours`` linked shots, and the linked shots form one graph.

``shot_links`` measures this for any set of cameras (the evaluator uses it on routes);
``connect_shots`` adds candidates until the planner's shots meet it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from coverplan.errors import ParameterError
from coverplan.runs import run_offsets

# "centroid": the rays of two photos meet at the centroid of all the samples both see.
# "faces": the shared samples are grouped by the way they face (FACE_BINS directions) and each
# group is judged on its own: its rays meet within max_pair_deg at the group's centroid and both
# photos see it within LINK_INCIDENCE_DEG of its normal; only the groups that pass count towards
# the overlap. Across a corner the centroid lies inside the building, where two photos on
# either side look alike, although on each face one of them sees the wall edge-on.
# "samples": each shared sample is judged on its own: both photos see it within
# LINK_INCIDENCE_DEG of its normal and their rays to it meet within max_pair_deg; only those
# samples count towards the overlap (the definition tests/independent.py counts one by one).
LINK_TESTS = ("centroid", "faces", "samples")
LINK_INCIDENCE_DEG = 60.0
FACE_BINS = 64


@dataclass(frozen=True)
class MatchRule:
    """When SfM can be expected to match two photos, and what every photo needs.

    Parameters
    ----------
    max_pair_deg : float
        The widest angle between two views SfM is expected to match.
    min_overlap : float
        The least share of a photo's surface two linked photos share.
    min_neighbours : int
        Links every photo needs.
    sharp_views : int
        Views per sample at its sharp incidence; 0 asks none.
    framed_views : int
        Views per sample that its face fills; 0 asks none.
    braced : bool
        No photo the links hang on.
    min_cut : int
        Links that join every group of photos to the rest (knitting.py); below 2 asks nothing.
    link_test : {"centroid", "faces", "samples"}
        How the shared surface's rays are judged.
    """

    max_pair_deg: float = 35.0
    min_overlap: float = 0.3
    min_neighbours: int = 2
    sharp_views: int = 1  # views per sample at its sharp incidence (``sharp_targets``); 0: none asked
    framed_views: int = 0  # views per sample that its face fills (framing.py); 0: none asked (the default until
    # field runs under the same suns show it helps: docs/reconstruction.md)
    braced: bool = True  # no photo the links hang on (bracing.py); False: one piece is enough
    min_cut: int = 0  # links across any cut between groups of photos (knitting.py); 0: not asked
    link_test: str = "centroid"  # LINK_TESTS: how the shared surface's rays are judged

    @property
    def lean(self) -> bool:
        """Whether plans under this rule are chosen lean (``planning.selecting.lean``): under the "samples"
        link test only."""
        return self.link_test == "samples"

    def __post_init__(self):
        if self.link_test not in LINK_TESTS:
            raise ParameterError(f"the link test (--link-test) must be one of {', '.join(LINK_TESTS)}, "
                                 f"got {self.link_test!r}")
        if not 0 < self.max_pair_deg < 90:
            raise ParameterError(f"the widest matchable pair (--max-pair-deg) must be in (0, 90) deg, "
                                 f"got {self.max_pair_deg:g}")
        if not 0 < self.min_overlap <= 1:
            raise ParameterError(f"the overlap of linked photos (--min-overlap) must be in (0, 1], got {self.min_overlap:g}")
        if int(self.min_neighbours) != self.min_neighbours or self.min_neighbours < 0:
            raise ParameterError(f"linked neighbours per photo (--min-neighbours) must be a whole number >= 0, "
                                 f"got {self.min_neighbours!r}")
        if int(self.min_cut) != self.min_cut or self.min_cut < 0:
            raise ParameterError(f"links across a cut (--min-cut) must be a whole number >= 0, got {self.min_cut!r}")
        if int(self.sharp_views) != self.sharp_views or self.sharp_views < 0:
            raise ParameterError(f"sharp views per sample (--sharp-views) must be a whole number >= 0, "
                                 f"got {self.sharp_views!r}")
        if int(self.framed_views) != self.framed_views or self.framed_views < 0:
            raise ParameterError(f"framed views per sample (--framed-views) must be a whole number >= 0, "
                                 f"got {self.framed_views!r}")


def _link_matrix(shared, size_a, size_b, cx, cy, cz, pos_a, pos_b, rule: MatchRule) -> np.ndarray:
    """Links between rows (cameras a) and columns (cameras b) from shared-sample counts and
    the sums of the shared samples' coordinates."""
    shared = np.asarray(shared, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = shared / np.maximum(np.minimum(size_a[:, None], size_b[None, :]), 1)
        centre = np.stack([cx, cy, cz], axis=-1) / np.maximum(shared, 1)[..., None]
    ra = pos_a[:, None, :] - centre
    rb = pos_b[None, :, :] - centre
    cos = np.einsum("ijk,ijk->ij", ra, rb) / np.maximum(
        np.linalg.norm(ra, axis=-1) * np.linalg.norm(rb, axis=-1), 1e-12)
    return (shared > 0) & (frac >= rule.min_overlap) & (cos >= np.cos(np.radians(rule.max_pair_deg)))


def _products(va: sp.csr_matrix, vb: sp.csr_matrix, points: np.ndarray):
    """Shared-sample counts and coordinate sums between the rows of va and of vb (dense)."""
    vbt = vb.T.tocsc()
    shared = (va @ vbt).toarray()
    sums = [(va.multiply(points[:, k][None, :]).tocsr() @ vbt).toarray() for k in range(3)]
    return shared, sums


def shot_links(vis: sp.csr_matrix, positions: np.ndarray, points: np.ndarray,
               rule: MatchRule = MatchRule(), normals: np.ndarray | None = None) -> np.ndarray:
    """Boolean (n, n) matrix: which of the n cameras (rows of ``vis``) SfM should match.
    ``normals`` (samples x 3): needed by the "faces" and "samples" link tests.

    Parameters
    ----------
    vis : scipy.sparse.csr_matrix
        Cameras by samples.
    positions : (n, 3) float
        Camera centres.
    points : (m, 3) float
        Samples.
    rule : MatchRule
        The matching rule.
    normals : (m, 3) float, optional
        Sample normals.

    Returns
    -------
    (n, n) bool
        Links.
    """
    if rule.link_test in ("faces", "samples"):
        return candidate_links(vis, positions, points, rule, normals=normals).toarray() > 0
    vis = sp.csr_matrix(vis, dtype=float)
    size = np.asarray(vis.sum(axis=1)).ravel()
    shared, (cx, cy, cz) = _products(vis, vis, points)
    links = _link_matrix(shared, size, size, cx, cy, cz, positions, positions, rule)
    np.fill_diagonal(links, False)
    return links


def candidate_links(vis: sp.csr_matrix, positions: np.ndarray, points: np.ndarray,
                    rule: MatchRule = MatchRule(), rows: np.ndarray | None = None,
                    normals: np.ndarray | None = None) -> sp.csr_matrix:
    """Sparse symmetric link graph over all rows of ``vis``, by the same test as ``shot_links``
    (only pairs that share samples are ever looked at, so it stays sparse). With ``rows``, only
    the links that have one of these rows at an end. ``normals`` (samples x 3): needed by
    ``rule.link_test == "faces"``.

    Whether two rows link depends on those two rows alone, to the last bit (each sum runs over
    their shared samples in column order), so links worked out for any subset of rows agree
    with the whole graph's.

    Parameters
    ----------
    vis : scipy.sparse.csr_matrix
        Candidates by samples.
    positions : (n, 3) float
        Candidate centres.
    points : (m, 3) float
        Samples.
    rule : MatchRule
        The matching rule.
    rows : (k,) int, optional
        Only links with one of these rows at an end.
    normals : (m, 3) float, optional
        Sample normals.

    Returns
    -------
    scipy.sparse.csr_matrix
        (n, n) links.
    """
    vis = sp.csr_matrix(vis, dtype=float)
    n = vis.shape[0]
    rows = np.arange(n) if rows is None else np.asarray(rows, dtype=np.int64)
    size = np.asarray(vis.sum(axis=1)).ravel()
    listed = np.zeros(n, dtype=bool)
    listed[rows] = True
    if rule.link_test == "faces":
        r, c = _face_links(vis, rows, listed, size, positions, points, normals, rule)
    elif rule.link_test == "samples":
        r, c = _sample_links(vis, listed, size, positions, points, normals, rule)
    else:
        r, c, shared, centre = _shared_entries(vis[rows], rows, vis.T.tocsc(), points)
        keep = ((r < c) | ~listed[c]) & (shared >= rule.min_overlap * np.minimum(size[r], size[c]))
        r, c, centre = r[keep], c[keep], centre[keep]
        ok = _ray_cos(positions[r] - centre, positions[c] - centre) >= np.cos(np.radians(rule.max_pair_deg))
        r, c = r[ok], c[ok]
    return sp.csr_matrix((np.ones(2 * len(r)), (np.concatenate([r, c]), np.concatenate([c, r]))), shape=(n, n))


def _ray_cos(ra: np.ndarray, rb: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", ra, rb) / np.maximum(np.linalg.norm(ra, axis=1) * np.linalg.norm(rb, axis=1), 1e-12)


def _shared_entries(mine: sp.csr_matrix, rows: np.ndarray, vt: sp.csc_matrix, points: np.ndarray):
    """Every pair (row of ``mine``, column of ``vt``) that shares samples: the global row
    ``rows[i]``, the column, the count of shared samples and their centroid (k, 3)."""
    shared = (mine @ vt).tocsr()
    # The sums of the shared samples' coordinates: x and y in one complex product, z in
    # another. Coordinates shifted to be positive, so the sums have exactly the pattern of
    # ``shared``; products of one pattern come out in one order, so their data arrays line up
    # entry for entry without sorting (checked; sorted if not). 1.5x faster than three
    # products each sorted, the same links.
    low = points.min(axis=0) if len(points) else np.zeros(3)
    shifted = points - low + 1.0
    j = mine.indices
    xy = sp.csr_matrix((shifted[j, 0] + 1j * shifted[j, 1], j, mine.indptr), shape=mine.shape) @ vt
    z = sp.csr_matrix((shifted[j, 2], j, mine.indptr), shape=mine.shape) @ vt
    xy, z = xy.tocsr(), z.tocsr()
    if not all(np.array_equal(m.indptr, shared.indptr) and np.array_equal(m.indices, shared.indices) for m in (xy, z)):
        for m in (shared, xy, z):
            m.sort_indices()
    centre = (np.column_stack([xy.data.real, xy.data.imag, z.data]) / shared.data[:, None] + (low - 1.0))
    r = rows[np.repeat(np.arange(shared.shape[0]), np.diff(shared.indptr))]
    return r, shared.indices, shared.data, centre


def face_groups(normals: np.ndarray, bins: int = FACE_BINS) -> np.ndarray:
    """(n,) int: the ``facing_bins`` direction nearest each normal (n, 3).

    Parameters
    ----------
    normals : (n, 3) float
        Unit normals.
    bins : int
        Directions.

    Returns
    -------
    (n,) int
        Direction indices.
    """
    from coverplan.shots.framing import facing_bins
    return np.argmax(np.asarray(normals, dtype=float).reshape(-1, 3) @ facing_bins(bins).T, axis=1)


def _face_links(vis: sp.csr_matrix, rows: np.ndarray, listed: np.ndarray, size: np.ndarray, positions: np.ndarray,
                points: np.ndarray, normals: np.ndarray | None, rule: MatchRule):
    """The pairs (r, c) that pass the "faces" link test (``LINK_TESTS``)."""
    if normals is None:
        raise ValueError("the faces link test needs the samples' normals")
    group = face_groups(normals)
    order = np.argsort(group, kind="stable")
    bounds = np.searchsorted(group[order], np.arange(FACE_BINS + 1))
    by_face = vis[:, order].tocsc()
    cos_pair, cos_inc = np.cos(np.radians(rule.max_pair_deg)), np.cos(np.radians(LINK_INCIDENCE_DEG))
    found = []
    for g in np.flatnonzero(np.diff(bounds)):  # one sparse product per direction the surface faces
        cols = order[bounds[g]:bounds[g + 1]]
        face = by_face[:, bounds[g]:bounds[g + 1]].tocsr()
        r, c, shared, centre = _shared_entries(face[rows], rows, face.T.tocsc(), points[cols])
        keep = (r < c) | ~listed[c]
        r, c, shared, centre = r[keep], c[keep], shared[keep], centre[keep]
        normal = normals[cols].sum(axis=0)
        normal = normal / max(np.linalg.norm(normal), 1e-12)
        ra, rb = positions[r] - centre, positions[c] - centre
        ok = ((_ray_cos(ra, rb) >= cos_pair) & (ra @ normal >= cos_inc * np.linalg.norm(ra, axis=1))
              & (rb @ normal >= cos_inc * np.linalg.norm(rb, axis=1)))
        found.append((r[ok], c[ok], shared[ok]))
    n = vis.shape[0]
    r, c, shared = (np.concatenate(x) for x in zip(*found)) if found else (np.zeros(0, np.int64),) * 3
    counted = sp.coo_matrix((shared, (r, c)), shape=(n, n)).tocsr()
    counted.sum_duplicates()
    counted = counted.tocoo()
    r, c = counted.row.astype(np.int64), counted.col.astype(np.int64)
    ok = counted.data >= rule.min_overlap * np.minimum(size[r], size[c])
    return r[ok], c[ok]


PAIRS_PER_CHUNK = 4_000_000  # view pairs judged at once by the "samples" link test


def following_pairs(entries: np.ndarray, later: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each entry paired with the ``later`` entries that follow it.

    Parameters
    ----------
    entries : (k,) int
        Positions in an array grouped by sample (one sample's views contiguous).
    later : (k,) int
        How many entries of the same sample follow each one.

    Returns
    -------
    a, b : (m,) int
        ``a[i] < b[i]``: every unordered pair of one sample's entries once, for the entries given.
    """
    a = np.repeat(entries, later)
    b = a + 1 + run_offsets(later)
    return a, b


def _sample_links(vis: sp.csr_matrix, listed: np.ndarray, size: np.ndarray, positions: np.ndarray,
                  points: np.ndarray, normals: np.ndarray | None, rule: MatchRule):
    """The pairs (r, c), r < c, at least one of them listed, that pass the "samples" link test
    (``LINK_TESTS``): every pair of views of every sample, judged in chunks of samples."""
    if normals is None:
        raise ValueError("the samples link test needs the samples' normals")
    csc = sp.csc_matrix(vis)
    csc.sort_indices()
    n, n_samples = csc.shape
    cam = csc.indices.astype(np.int64)
    samp = np.repeat(np.arange(n_samples), np.diff(csc.indptr))
    ray = positions[cam] - points[samp]
    ray /= np.maximum(np.linalg.norm(ray, axis=1), 1e-12)[:, None]
    square = np.einsum("ij,ij->i", ray, normals[samp]) >= np.cos(np.radians(LINK_INCIDENCE_DEG))
    cam, samp, ray = cam[square], samp[square], ray[square]
    count = np.bincount(samp, minlength=n_samples)
    start = np.cumsum(count) - count
    cos_pair = np.cos(np.radians(rule.max_pair_deg))
    # Each unordered pair of a sample's views once: an entry pairs with the later entries of its
    # sample, whose cameras have higher indices (the columns' rows are sorted), so (a, b) is (low, high).
    later = (start + count)[samp] - np.arange(len(samp)) - 1
    work = np.cumsum(later)
    found = []
    lo = 0
    while lo < len(samp):
        hi = max(int(np.searchsorted(work, (work[lo - 1] if lo else 0) + PAIRS_PER_CHUNK, "right")), lo + 1)
        a, b = following_pairs(np.arange(lo, hi), later[lo:hi])
        ca, cb = cam[a], cam[b]
        keep = (listed[ca] | listed[cb]) & (np.einsum("ij,ij->i", ray[a], ray[b]) >= cos_pair)
        found.append((ca[keep], cb[keep]))
        lo = hi
    r, c = (np.concatenate(x) for x in zip(*found)) if found else (np.zeros(0, np.int64),) * 2
    counted = sp.coo_matrix((np.ones(len(r)), (r, c)), shape=(n, n)).tocsr()
    counted.sum_duplicates()
    counted = counted.tocoo()
    r, c = counted.row.astype(np.int64), counted.col.astype(np.int64)
    ok = counted.data >= rule.min_overlap * np.minimum(size[r], size[c])
    return r[ok], c[ok]


def extend_links(vis: sp.csr_matrix, positions: np.ndarray, points: np.ndarray, rule: MatchRule,
                 known: sp.csr_matrix, normals: np.ndarray | None = None) -> sp.csr_matrix:
    """``candidate_links`` of every row of ``vis`` when ``known`` holds those among its first
    ``known.shape[0]`` rows: only the other rows' links are worked out (the same graph, as a
    link depends on its two rows alone).

    Parameters
    ----------
    vis : scipy.sparse.csr_matrix
        Candidates by samples.
    positions : (n, 3) float
        Candidate centres.
    points : (m, 3) float
        Samples.
    rule : MatchRule
        The matching rule.
    known : scipy.sparse.csr_matrix
        The links of the first rows.
    normals : (m, 3) float, optional
        Sample normals.

    Returns
    -------
    scipy.sparse.csr_matrix
        (n, n) links.
    """
    n = vis.shape[0]
    old = known.tocoo()
    links = (candidate_links(vis, positions, points, rule, rows=np.arange(known.shape[0], n), normals=normals)
             + sp.csr_matrix((old.data, (old.row, old.col)), shape=(n, n))).tocsr()
    links.sum_duplicates()
    return links
