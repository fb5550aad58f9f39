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
from scipy.sparse.csgraph import connected_components

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


def cut_shots(links: sp.spmatrix) -> np.ndarray:
    """The shots (rows of the symmetric ``links``) whose removal splits their piece of the
    graph: its articulation points, by Tarjan's low-link on an explicit stack.

    Parameters
    ----------
    links : (n, n) sparse or dense
        Symmetric link matrix.

    Returns
    -------
    (k,) int
        Sorted indices of the cut shots.
    """
    return np.flatnonzero(depth_first(links)["cut"])


def depth_first(links: sp.spmatrix) -> dict:
    """Tarjan's depth-first search of the symmetric ``links`` (n, n), on an explicit stack.

    Parameters
    ----------
    links : scipy.sparse.spmatrix
        Symmetric links.

    Returns
    -------
    dict of (n,) arrays
        ``order``: preorder number (a subtree holds the numbers ``order[w]`` up to
        ``order[w] + size[w]``); ``low``: its low-link; ``parent``: -1 at a root; ``size``:
        shots in the subtree; ``root``: the root of the shot's tree; ``cut``: bool, the cut shots.
    """
    g = sp.csr_matrix(links)
    n = g.shape[0]
    indptr, indices = g.indptr, g.indices
    order = np.full(n, -1, dtype=np.int64)
    low = np.zeros(n, dtype=np.int64)
    parent = np.full(n, -1, dtype=np.int64)
    size = np.ones(n, dtype=np.int64)
    root_of = np.zeros(n, dtype=np.int64)
    cut = np.zeros(n, dtype=bool)
    clock = 0
    for root in range(n):
        if order[root] >= 0:
            continue
        order[root] = low[root] = clock
        root_of[root] = root
        clock += 1
        children = 0
        stack = [(root, indptr[root])]
        while stack:
            v, at = stack[-1]
            if at < indptr[v + 1]:
                stack[-1] = (v, at + 1)
                w = indices[at]
                if w == v:
                    continue
                if order[w] < 0:
                    parent[w] = v
                    root_of[w] = root
                    order[w] = low[w] = clock
                    clock += 1
                    if v == root:
                        children += 1
                    stack.append((w, indptr[w]))
                elif w != parent[v]:
                    low[v] = min(low[v], order[w])
            else:
                stack.pop()
                p = parent[v]
                if p >= 0:
                    low[p] = min(low[p], low[v])
                    size[p] += size[v]
                    if p != root and low[v] >= order[p]:
                        cut[p] = True
        if children > 1:
            cut[root] = True
    return {"order": order, "low": low, "parent": parent, "size": size, "root": root_of, "cut": cut}


def graph_summary(links: np.ndarray, rule: MatchRule = MatchRule()) -> dict:
    """Neighbour counts and connected pieces of a link matrix, as the reports state them.

    Parameters
    ----------
    links : (n, n) bool
        Links.
    rule : MatchRule
        Gives ``min_neighbours``.

    Returns
    -------
    dict
        Shots, components, largest component, shots short of neighbours, cut shots.
    """
    n = len(links)
    if n == 0:
        return {"shots": 0, "components": 0, "largest_component": 0, "shots_short_of_neighbours": 0,
                "median_neighbours": 0.0, "cut_shots": 0}
    degree = links.sum(axis=1)
    n_comp, label = connected_components(sp.csr_matrix(links), directed=False)
    return {"shots": int(n), "components": int(n_comp),
            "largest_component": int(np.bincount(label).max()),
            "shots_short_of_neighbours": int((degree < rule.min_neighbours).sum()),
            "median_neighbours": float(np.median(degree)), "cut_shots": len(cut_shots(links))}


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


def connect_shots(vis: sp.csr_matrix, positions: np.ndarray, points: np.ndarray, chosen: np.ndarray,
                  rule: MatchRule = MatchRule(), max_added: int | None = None,
                  links: sp.csr_matrix | None = None, normals: np.ndarray | None = None) -> np.ndarray:
    """Add candidates (rows of ``vis``) to ``chosen`` until every chosen shot has
    ``rule.min_neighbours`` links and the links join all shots in one piece, or nothing helps.
    ``links``: ``candidate_links(vis, positions, points, rule)`` if already worked out.

    Shots short of neighbours get, one at a time, the candidate linked to most of them. Pieces
    left apart are joined along chains of linked candidates (Dijkstra over the candidate link
    graph from the largest piece), two ways: every piece at once along its shortest chain, or
    the nearest piece first, counting the candidates already taken as free, then again from
    the grown piece (a Steiner-tree heuristic: later chains run through earlier ones). Neither
    is the shorter on every scene, so for a lean rule (``MatchRule.lean``) both run and the one
    adding fewer shots is kept; otherwise the first alone.

    Parameters
    ----------
    vis : scipy.sparse.csr_matrix
        Candidates by samples.
    positions : (n, 3) float
        Candidate centres.
    points : (m, 3) float
        Samples.
    chosen : (k,) int
        Chosen candidates.
    rule : MatchRule
        The matching rule.
    max_added : int, optional
        The most candidates added.
    links : scipy.sparse.csr_matrix, optional
        The candidates' links.
    normals : (m, 3) float, optional
        Sample normals.

    Returns
    -------
    (j,) int
        ``chosen`` and the candidates added.
    """
    chosen = [int(j) for j in chosen]
    if len(chosen) < 2:
        return np.array(chosen, dtype=np.int64)
    budget = len(chosen) if max_added is None else int(max_added)
    links = candidate_links(vis, positions, points, rule, normals=normals) if links is None else links
    links = sp.csr_matrix(links)
    ways = (False, True) if rule.lean else (False,)
    joined = [_connect(links, chosen, rule.min_neighbours, budget, nearest) for nearest in ways]
    return min(joined, key=len)


def _connect(links: sp.csr_matrix, start: list[int], min_neighbours: int, budget: int, nearest: bool) -> np.ndarray:
    """``connect_shots`` with one way of joining the pieces (``nearest``: the Steiner one)."""
    from scipy.sparse.csgraph import dijkstra

    chosen = list(start)
    n = links.shape[0]
    taken = np.zeros(n, dtype=bool)
    taken[chosen] = True
    added = 0

    def add(j: int) -> None:
        nonlocal added
        chosen.append(int(j))
        taken[j] = True
        added += 1

    def pieces():
        idx = np.array(chosen)
        n_comp, label = connected_components(links[idx][:, idx], directed=False)
        return idx, n_comp, label

    def chain(pred, end) -> bool:
        """Add the untaken candidates on the chain from ``end`` back to the largest piece."""
        grew = False
        node = pred[end]
        while node >= 0 and added < budget:
            if not taken[node]:
                add(node)
                grew = True
            elif not nearest:  # the old chains stop at the first shot already taken
                break
            node = pred[node]
        return grew

    for _pass in range(3):
        # 1. every shot its neighbours (links is symmetric: degrees are one product)
        while added < budget:
            degree = links @ taken.astype(float)
            short_mask = taken & (degree < min_neighbours)
            if not short_mask.any():
                break
            score = links @ short_mask.astype(float)
            score[taken] = 0
            best = int(np.argmax(score))
            if score[best] <= 0:
                break
            add(best)
        # 2. one piece
        idx, n_comp, label = pieces()
        if n_comp == 1 or added >= budget:
            break
        grew = False
        if not nearest:
            main = idx[label == np.argmax(np.bincount(label))]
            dist, pred, _src = dijkstra(links, indices=main, unweighted=True, min_only=True,
                                        return_predecessors=True)
            for comp in range(n_comp):
                members = idx[label == comp]
                if np.isin(members, main).any():
                    continue
                end = members[np.argmin(dist[members])]
                if np.isfinite(dist[end]):
                    grew |= chain(pred, end)
        else:
            step = links.copy()
            step.eliminate_zeros()
            while n_comp > 1 and added < budget:
                main_label = int(np.argmax(np.bincount(label)))
                # entering a taken candidate costs (almost) nothing: chains reuse the shots there
                step.data = np.where(taken[step.indices], 1e-6, 1.0)
                dist, pred, _src = dijkstra(step, directed=True, indices=idx[label == main_label], min_only=True,
                                            return_predecessors=True)
                rest = idx[label != main_label]
                end = rest[np.argmin(dist[rest])]
                if not np.isfinite(dist[end]) or not chain(pred, end):
                    break
                grew = True
                idx, n_comp, label = pieces()
        if not grew:
            break
    return np.array(chosen, dtype=np.int64)
