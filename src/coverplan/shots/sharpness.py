"""Sharp views: how square a view is to the surface, and the views each sample wants at its sharpest
(``SHARP_INCIDENCE_DEG``, or its best view plus ``SHARP_SLACK_DEG`` where none is that square)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

# "centroid": the rays of two photos meet at the centroid of all the samples both see.
# "faces": the shared samples are grouped by the way they face (FACE_BINS directions) and each
# group is judged on its own: its rays meet within max_pair_deg at the group's centroid and both
# photos see it within LINK_INCIDENCE_DEG of its normal; only the groups that pass count towards
# the overlap. Across a corner the centroid lies inside the building, where two photos on
# either side look alike, although on each face one of them sees the wall edge-on.
# "samples": each shared sample is judged on its own: both photos see it within
# LINK_INCIDENCE_DEG of its normal and their rays to it meet within max_pair_deg; only those
# samples count towards the overlap (the definition tests/independent.py counts one by one).


# Measured with simulate (ring prism, 161 photos, no sharp views asked): samples whose best
# view meets the surface within 30 deg of its normal were 98-100 % reconstructed, 30-36 deg
# 94 %, 36-42 deg 85 %, 42-48 deg 73 %, whatever their number of views; undersides, whose
# chosen views sat at a median 46 deg, 53 %. One sharp view per sample: 97.8 %, undersides 85 %.
SHARP_INCIDENCE_DEG = 35.0
SHARP_SLACK_DEG = 5.0  # where no view reaches 35 deg (undersides, gimbal up to +30 deg): the best + 5


def incidence_deg(cam: np.ndarray, pt: np.ndarray, positions: np.ndarray, points: np.ndarray,
                  normals: np.ndarray) -> np.ndarray:
    """Per (camera, sample) pair: the angle between the sample's normal and its ray to the camera.

    Parameters
    ----------
    cam, pt : (m,) int
        Camera and sample of each pair.
    positions : (c, 3) float
        Camera centres.
    points, normals : (n, 3) float
        Samples.

    Returns
    -------
    (m,) float
        Degrees.
    """
    ray = positions[cam] - points[pt]
    cos = np.einsum("ij,ij->i", ray, normals[pt]) / np.maximum(np.linalg.norm(ray, axis=1), 1e-12)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def best_incidence(pt: np.ndarray, incidence: np.ndarray, n_samples: int) -> np.ndarray:
    """Per sample: the smallest incidence of its (camera, sample) pairs (inf when it has none).

    Parameters
    ----------
    pt : (m,) int
        The sample of each pair.
    incidence : (m,) float
        Degrees.
    n_samples : int
        Samples.

    Returns
    -------
    (n_samples,) float
        Degrees.
    """
    best = np.full(n_samples, np.inf)
    np.minimum.at(best, pt, incidence)
    return best


def sharp_targets(pt: np.ndarray, incidence: np.ndarray, n_samples: int, limit_deg: float = SHARP_INCIDENCE_DEG,
                  slack_deg: float = SHARP_SLACK_DEG) -> np.ndarray:
    """Per sample: the incidence a sharp view must reach, ``limit_deg`` or, where no pair
    reaches that, the sample's best incidence plus ``slack_deg``.

    Parameters
    ----------
    pt : (m,) int
        The sample of each pair.
    incidence : (m,) float
        Degrees.
    n_samples : int
        Samples.
    limit_deg : float
        The sharp incidence.
    slack_deg : float
        Degrees over the best allowed.

    Returns
    -------
    (n_samples,) float
        Degrees.
    """
    return np.maximum(limit_deg, best_incidence(pt, incidence, n_samples) + slack_deg)


def sharp_view_matrix(cam: np.ndarray, pt: np.ndarray, incidence: np.ndarray, n_cands: int,
                      n_samples: int, targets: np.ndarray | None = None) -> sp.csr_matrix:
    """Candidates x samples, 1 where the view is sharp: within the sample's ``targets``
    (per sample, degrees; default ``sharp_targets``).

    Parameters
    ----------
    cam, pt : (m,) int
        Candidate and sample of each pair.
    incidence : (m,) float
        Degrees.
    n_cands, n_samples : int
        The matrix's shape.
    targets : (n_samples,) float, optional
        Degrees.

    Returns
    -------
    scipy.sparse.csr_matrix
        Candidates by samples.
    """
    if targets is None:
        targets = sharp_targets(pt, incidence, n_samples)
    sharp = incidence <= targets[pt]
    return sp.csr_matrix((np.ones(int(sharp.sum())), (cam[sharp], pt[sharp])), shape=(n_cands, n_samples))


def add_sharp_views(cam: np.ndarray, pt: np.ndarray, incidence: np.ndarray, n_cands: int, area: np.ndarray,
                    chosen: np.ndarray, views: int = 1, min_gain_m2: float = 1.0) -> np.ndarray:
    """Add candidates to ``chosen`` until every sample has ``views`` views at its sharp
    incidence (``sharp_targets``) or no candidate adds ``min_gain_m2`` of surface that lacks
    them (``add_wanted_views``).

    Parameters
    ----------
    cam, pt : (m,) int
        Candidate and sample of each pair.
    incidence : (m,) float
        Degrees.
    n_cands : int
        Candidates.
    area : (n,) float
        Sample areas, square metres.
    chosen : (k,) int
        Chosen candidates.
    views : int
        Sharp views per sample.
    min_gain_m2 : float
        The least surface a candidate must add.

    Returns
    -------
    (j,) int
        ``chosen`` and the candidates added.
    """
    m = sharp_view_matrix(cam, pt, incidence, n_cands, len(area))
    return add_wanted_views(m, area, chosen, views, min_gain_m2)


def add_wanted_views(m: sp.csr_matrix, area: np.ndarray, chosen: np.ndarray, views: int = 1,
                     min_gain_m2: float = 1.0) -> np.ndarray:
    """Add candidates to ``chosen`` until every sample has ``views`` of the views ``m``
    (candidates x samples, 1 where the view is of the kind wanted) or no candidate adds
    ``min_gain_m2`` of surface that lacks them. Greedy: each time the candidate giving most
    such surface a wanted view. A sample is asked for no more than its candidates offer.

    Parameters
    ----------
    m : scipy.sparse.csr_matrix
        Candidates by samples.
    area : (n,) float
        Sample areas, square metres.
    chosen : (k,) int
        Chosen candidates.
    views : int
        Wanted views per sample.
    min_gain_m2 : float
        The least surface a candidate must add.

    Returns
    -------
    (j,) int
        ``chosen`` and the candidates added.
    """
    m = sp.csr_matrix(m)
    n_cands = m.shape[0]
    offered = np.asarray(m.sum(axis=0)).ravel()
    taken = np.zeros(n_cands, dtype=bool)
    taken[np.asarray(chosen, dtype=np.int64)] = True
    have = np.asarray(m[taken].sum(axis=0)).ravel()
    want = np.minimum(views, offered)
    out = [int(j) for j in chosen]
    while True:
        short = (have < want).astype(float) * area
        gain = m @ short
        gain[taken] = 0.0
        best = int(np.argmax(gain))
        if gain[best] < min_gain_m2:
            break
        taken[best] = True
        out.append(best)
        have += m[best].toarray().ravel()
    return np.array(out, dtype=np.int64)
