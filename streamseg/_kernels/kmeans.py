"""Lloyd iterations of k-means (temporal reduction and initializations of ACA).

In numba with the GIL released, so the daemon's relabel worker clusters frames on one core
while ingest runs on the other.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def _add_squares(acc, x, row, k):
    for c in range(k):
        t = x - row[c]
        acc[c] += t * t


@njit(cache=True, nogil=True)
def lloyd(X, centres, n_iter):
    """Lloyd's algorithm from ``centres`` (updated in place); returns ``(n,)`` int64 labels.

    Squared Euclidean distances; ties go to the lower cluster index. A cluster left empty
    takes the point farthest from its own centre (clusters checked in index order), so every
    cluster keeps at least one point when ``n >= k`` and the points are distinct; a cluster
    still empty (identical points) keeps its centre. Stops when the labels repeat.
    """
    n, d = X.shape
    k = centres.shape[0]
    labels = np.full(n, -1, np.int64)
    new = np.empty(n, np.int64)
    dist = np.empty((n, k))
    counts = np.zeros(k, np.int64)
    sums = np.zeros((k, d))
    ct = np.empty((d, k))  # centres transposed: the loop over clusters reads one row
    acc = np.empty(k)
    for _ in range(n_iter):
        for c in range(k):
            for j in range(d):
                ct[j, c] = centres[c, j]
        for i in range(n):
            # every cluster's sum over j in the order j = 0..d-1, as one sum per cluster
            # would add them, but all clusters at once (a loop that vectorizes)
            acc[:] = 0.0
            for j in range(d):
                _add_squares(acc, X[i, j], ct[j], k)
            best = np.inf
            bi = 0
            for c in range(k):
                s = acc[c]
                dist[i, c] = s
                if s < best:
                    best = s
                    bi = c
            new[i] = bi
        counts[:] = 0
        for i in range(n):
            counts[new[i]] += 1
        for c in range(k):
            if counts[c] == 0:
                far = 0
                fd = -1.0
                for i in range(n):
                    if dist[i, new[i]] > fd:
                        fd = dist[i, new[i]]
                        far = i
                counts[new[far]] -= 1
                new[far] = c
                counts[c] += 1
                for cc in range(k):
                    dist[far, cc] = 0.0
        same = True
        for i in range(n):
            if new[i] != labels[i]:
                same = False
                break
        if same:
            break
        labels[:] = new
        sums[:] = 0.0
        for i in range(n):
            for j in range(d):
                sums[labels[i], j] += X[i, j]
        for c in range(k):
            if counts[c] == 0:  # identical points can leave a cluster empty: keep its centre
                continue
            for j in range(d):
                centres[c, j] = sums[c, j] / counts[c]
    return labels
