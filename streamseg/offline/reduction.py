"""Temporal reduction (Zhou et al. 2008, section 4.1).

Frames are clustered by k-means into ``k_reduce`` classes; each run of consecutive frames of
one class becomes one reduced frame (runs longer than ``cap`` are cut every ``cap`` frames, the
paper's "every 20 consecutive frames ... reduced to one frame"). The reduced frame is the mean
of the frames it stands for, so the Gaussian kernel still sees the pose, not only the class.
"""

from __future__ import annotations

import numpy as np

from streamseg.exceptions import ParameterError
from streamseg.offline.aca_init import kmeans


def reduce_frames(X, k_reduce: int, cap: int, rng: np.random.Generator):
    """Reduce ``X`` (n, d) to (m, d) run means.

    Returns
    -------
    Xr : (m, d) float64
    runs : tuple of two (m,) int64 arrays
        ``(starts, ends)``: reduced frame u stands for original frames ``starts[u]..ends[u]-1``.
    classes : (m,) int64
        k-means class of each reduced frame (used by the propagated initialization).
    """
    X = np.asarray(X, dtype=np.float64)
    if k_reduce < 1 or cap < 1:
        raise ParameterError(f"k_reduce={k_reduce!r}, cap={cap!r} are invalid: expected >= 1")
    n = X.shape[0]
    lab = kmeans(X, k_reduce, rng)
    bounds = [0]
    for i in range(1, n):
        if lab[i] != lab[i - 1] or i - bounds[-1] >= cap:
            bounds.append(i)
    starts = np.asarray(bounds, dtype=np.int64)
    ends = np.append(starts[1:], n).astype(np.int64)
    sums = np.add.reduceat(X, starts, axis=0)
    Xr = sums / (ends - starts)[:, None]
    return Xr, (starts, ends), lab[starts].astype(np.int64)


def expand_labels(reduced_labels, runs, n: int) -> np.ndarray:
    """Per-frame labels (n,) from labels of the reduced frames (m,) and their ``runs``."""
    starts, ends = runs
    return np.repeat(np.asarray(reduced_labels), ends - starts)[:n]
