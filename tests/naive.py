"""Slow, obvious reference implementations: the test twin of every numba kernel.

Nothing here is fast or clever on purpose; each function follows the paper's definition.
"""

from __future__ import annotations

import numpy as np  # noqa: F401

# --- skeleton features (issue 2) -------------------------------------------------------------


# --- LOF, sliding histograms, peaks (issue 3) ------------------------------------------------


# --- ACA: DTAK, DP segmentation, kernel k-means (issue 4) ------------------------------------


def naive_dtak_p(K, a0, a1, b0, b1):
    """P of eq. 7 by the literal recursion (memoized); returns dict (i, j) -> p_{i,j}."""
    memo = {}

    def p(i, j):
        if i == 0 and j == 0:
            return 0.0
        if i == 0 or j == 0:
            return float("-inf")
        if (i, j) not in memo:
            k = K[a0 + i - 1, b0 + j - 1]
            memo[(i, j)] = max(p(i - 1, j) + k, p(i - 1, j - 1) + 2 * k, p(i, j - 1) + k)
        return memo[(i, j)]

    return {(i, j): p(i, j) for i in range(a1 - a0 + 1) for j in range(b1 - b0 + 1)}


def naive_dtak(K, a0, a1, b0, b1):
    """DTAK of eq. 6 between frame ranges [a0, a1) and [b0, b1) of kernel K."""
    na, nb = a1 - a0, b1 - b0
    return naive_dtak_p(K, a0, a1, b0, b1)[(na, nb)] / (na + nb)


def naive_dist(K, seg, old_segs, old_labels, c):
    """dist_c of eq. 3 for segment ``seg`` = (s, e) against the centre of cluster c."""
    members = [sg for sg, lab in zip(old_segs, old_labels) if lab == c]
    nc = len(members)
    self_k = naive_dtak(K, seg[0], seg[1], seg[0], seg[1])
    f = sum(naive_dtak(K, seg[0], seg[1], s, e) for s, e in members)
    h = sum(naive_dtak(K, s1, e1, s2, e2) for s1, e1 in members for s2, e2 in members)
    return self_k - 2 * f / nc + h / nc**2


def all_tilings(n, wmin, wmax):
    """Every list of (start, end) covering 0..n with lengths in [wmin, wmax]."""
    if n == 0:
        return [[]]
    out = []
    for w in range(wmin, min(wmax, n) + 1):
        for rest in all_tilings(n - w, wmin, wmax):
            out.append([(0, w)] + [(s + w, e + w) for s, e in rest])
    return out


def naive_dp(K, old_segs, old_labels, k, wmin, wmax):
    """Brute force over all tilings: min over segmentations of sum of min_c dist_c."""
    used = sorted(set(old_labels))
    best = float("inf")
    for tiling in all_tilings(K.shape[0], wmin, wmax):
        cost = sum(min(naive_dist(K, seg, old_segs, old_labels, c) for c in used)
                   for seg in tiling)
        best = min(best, cost)
    return best


def naive_objective(K, segs, labels):
    """Eq. 5 for segmentation ``segs`` with ``labels`` (centres from the segmentation itself)."""
    return sum(naive_dist(K, seg, segs, labels, c) for seg, c in zip(segs, labels))


def naive_kernel_kmeans(K, labels, k, max_iter=100):
    """Kernel k-means (eq. 2-4) by Lloyd steps from ``labels``; an empty cluster takes the point
    farthest from its own centre among clusters with >= 2 points. Returns final labels."""
    labels = np.array(labels)
    n = K.shape[0]

    def dists(lab):
        D = np.full((n, k), np.inf)
        for c in range(k):
            idx = np.flatnonzero(lab == c)
            if idx.size:
                D[:, c] = (np.diag(K) - 2 * K[:, idx].sum(1) / idx.size
                           + K[np.ix_(idx, idx)].sum() / idx.size**2)
        return D

    def reseed(lab):
        while True:
            counts = np.bincount(lab, minlength=k)
            empty = np.flatnonzero(counts == 0)
            movable = counts[lab] >= 2
            if empty.size == 0 or not movable.any():
                return lab
            own = dists(lab)[np.arange(n), lab]
            own[~movable] = -np.inf
            lab = lab.copy()
            lab[int(np.argmax(own))] = empty[0]

    for _ in range(max_iter):
        labels = reseed(labels)
        new = np.argmin(dists(labels), axis=1)
        if np.array_equal(new, labels):
            break
        labels = new
    return reseed(labels)


# --- repetitions: UKF, candidates (issue 6) --------------------------------------------------
