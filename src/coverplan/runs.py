"""Index arithmetic on runs: arrays laid out as consecutive groups of given lengths."""

from __future__ import annotations

import numpy as np


def run_offsets(lengths) -> np.ndarray:
    """Each element's position inside its run, for runs of ``lengths`` laid end to end.

    Parameters
    ----------
    lengths : (m,) int
        Run lengths (zeros allowed).

    Returns
    -------
    (lengths.sum(),) int
        0, 1, ..., lengths[0] - 1, 0, 1, ..., lengths[1] - 1, ...
    """
    lengths = np.asarray(lengths)
    return np.arange(int(lengths.sum())) - np.repeat(np.cumsum(lengths) - lengths, lengths)
