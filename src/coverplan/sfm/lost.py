"""Why a photo is not in the model: read from COLMAP's database (features, verified pairs)
and the models it made, so that a user knows whether to re-fly, re-shoot or look at the file."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from coverplan.sfm.database import open_database

PAIR_BASE = 2147483647  # COLMAP's pair id: PAIR_BASE * first image id + second image id
MIN_INLIERS = 15  # COLMAP's two-view verification keeps a pair from this many inliers (its default)
FEW_FEATURES = 100  # below this a photo is featureless to SIFT: sky, water, a blurred or blank frame


def _partners(pair_ids: np.ndarray, inliers: np.ndarray) -> dict[int, set[int]]:
    keep = np.asarray(pair_ids, dtype=np.int64)[np.asarray(inliers) >= MIN_INLIERS]
    first, second = keep // PAIR_BASE, keep % PAIR_BASE
    partners: dict[int, set[int]] = {}
    for a, b in zip(first.tolist(), second.tolist()):
        partners.setdefault(a, set()).add(b)
        partners.setdefault(b, set()).add(a)
    return partners


def lost_photos(pycolmap, database: Path, models: list, names: list[str]) -> list[tuple[str, str]]:
    """The photos of ``names`` outside the largest model, each with why.

    Parameters
    ----------
    pycolmap : module
    database : path
        COLMAP's database the models were made from.
    models : list of SfmModel
        The models, largest first (``SfmResult.models``).
    names : list of str
        The photos given to COLMAP, as it names them.

    Returns
    -------
    list of (str, str)
        ``(name, why)`` in the order of ``names``: in a smaller model (and how many of the
        largest model's photos it matched), too few features, matched no photo, or matched
        some yet could not be placed.
    """
    largest = set(models[0].image_names) if models else set()
    lost = [n for n in names if n not in largest]
    if not lost:
        return []
    model_of = {n: k for k, m in enumerate(models[1:], start=2) for n in m.image_names}
    db = open_database(pycolmap, database)
    try:
        ids = {im.name: int(im.image_id) for im in db.read_all_images()}
        features = {n: int(db.num_keypoints_for_image(ids[n])) for n in lost if n in ids}
        partners = _partners(*db.read_two_view_geometry_num_inliers())
    finally:
        db.close()
    largest_ids = {ids[n] for n in largest if n in ids}
    out = []
    for name in lost:
        matched = partners.get(ids.get(name, -1), set())
        linked = len(matched & largest_ids)
        if name in model_of:
            size = len(models[model_of[name] - 1].image_names)
            why = (f"in a separate model of {size} photos (model {model_of[name]}): matched {linked} of the "
                   "largest model's photos, too few to join it: photos overlapping both parts would")
        elif features.get(name, 0) < FEW_FEATURES:
            why = (f"{features.get(name, 0)} features: nothing SIFT can match (sky, water, a blurred or "
                   "blank frame)")
        elif not matched:
            why = f"matched no other photo ({features[name]} features): nothing it sees is seen by another photo"
        else:
            why = (f"matched {len(matched)} photos ({linked} in the model) but could not be placed: too little "
                   "overlap or too narrow a baseline")
        out.append((name, why))
    return out
