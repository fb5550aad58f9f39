"""Which photos of a large flight are worth matching: COLMAP's spatial pairs from the photos'
recorded positions, or each photo's co-visible partners from what it sees."""

from __future__ import annotations

import numpy as np


def covisible_pairs(seen: list[np.ndarray], cell: float, k: int) -> list[tuple[int, int]]:
    """Pairs of photos worth matching in a large flight: for each photo, the ``k`` photos that
    see most of the same scene (points its pixels hit, counted in cells of ``cell`` metres).

    Nearest camera positions are not enough: a flight round a tall block has photos a few
    metres apart looking at different walls, and photos of one wall from far apart.

    Parameters
    ----------
    seen : list of (m_i, 3) float
        Per photo, the scene points its pixels hit.
    cell : float
        Edge of the cells the points are counted in, m.
    k : int
        Partners per photo.

    Returns
    -------
    list of (int, int)
        Photo index pairs, i < j, each once.
    """
    import scipy.sparse as sp

    rows, cols = [], []
    keys: dict = {}
    for i, pts in enumerate(seen):
        if len(pts) == 0:
            continue
        cells = np.unique(np.floor(pts / cell).astype(np.int64), axis=0)
        ids = np.array([keys.setdefault(tuple(v), len(keys)) for v in cells])
        rows.append(np.full(len(ids), i))
        cols.append(ids)
    n = len(seen)
    if not rows:
        return []
    m = sp.csr_matrix((np.ones(sum(map(len, rows))), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n, len(keys)))
    shared = (m @ m.T).toarray()
    np.fill_diagonal(shared, 0)
    pairs = set()
    for i in range(n):
        best = np.argsort(-shared[i])[:k]
        for j in best[shared[i, best] > 0]:
            pairs.add((min(i, int(j)), max(i, int(j))))
    return sorted(pairs)


def spatial_pairs(positions: np.ndarray, neighbours: int, max_distance: float) -> list[tuple[int, int]]:
    """The pairs COLMAP's spatial matcher takes: each photo with its ``neighbours`` nearest
    other photos by recorded position that lie within ``max_distance`` metres.

    Parameters
    ----------
    positions : (n, 3) float
        Recorded positions (GNSS tags in the local frame).
    neighbours : int
        Nearest photos per photo.
    max_distance : float
        Metres.

    Returns
    -------
    list of (i, j) int, i < j
    """
    from scipy.spatial import cKDTree

    positions = np.asarray(positions, dtype=float).reshape(-1, 3)
    n = len(positions)
    k = min(int(neighbours) + 1, n)  # the photo itself comes first
    if k < 2:
        return []
    dist, nn = cKDTree(positions).query(positions, k=k, distance_upper_bound=float(max_distance))
    i = np.repeat(np.arange(n), k)
    j, d = nn.ravel(), dist.ravel()
    ok = np.isfinite(d) & (j != i) & (j < n)
    pairs = np.unique(np.sort(np.stack([i[ok], j[ok]], axis=1), axis=1), axis=0)
    return [(int(a), int(b)) for a, b in pairs]
