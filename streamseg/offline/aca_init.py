"""Initial segmentations for ACA (Zhou et al. 2008, section 4.2) and the small clustering
tools they need (k-means, spectral clustering). Lloyd's iterations run in a numba kernel
(``streamseg._kernels.kmeans``, GIL released), and so do the passes over a large affinity
matrix (``streamseg._kernels.affinity``); the rest is plain numpy/scipy.

Segmentations are triples of int64 arrays ``(starts, ends, labels)`` with
``starts[0] = 0``, ``ends[i] = starts[i + 1]``, ``ends[-1] = n``.
"""

from __future__ import annotations

import numpy as np

from streamseg._kernels.affinity import (
    propagated,
    scale_both,
    scaled_symmetric,
    symmetrized,
)
from streamseg._kernels.dtak import segment_kernel
from streamseg._kernels.kmeans import lloyd
from streamseg._kernels.lapack import leading_eigh
from streamseg.offline.aca_descent import frame_ids


def kmeans(X, k: int, rng: np.random.Generator, n_iter: int = 100) -> np.ndarray:
    """Lloyd's k-means with k-means++ seeding. ``X``: (n, d). Returns (n,) labels in 0..k-1.

    An emptied cluster is re-seeded with the point farthest from its centre, so every label in
    ``0..min(k, distinct rows)-1`` is used.
    """
    X = np.ascontiguousarray(X, dtype=np.float64)
    n = X.shape[0]
    k = int(min(k, n))
    centres = np.empty((k, X.shape[1]))
    centres[0] = X[rng.integers(n)]
    d2 = ((X - centres[0]) ** 2).sum(1)
    for c in range(1, k):
        total = d2.sum()
        i = rng.choice(n, p=d2 / total) if total > 0 else rng.integers(n)
        centres[c] = X[i]
        d2 = np.minimum(d2, ((X - centres[c]) ** 2).sum(1))
    return lloyd(X, centres, n_iter)


#: Above this many items the spectral embedding's k leading eigenvectors come from ARPACK
#: (``scipy.sparse.linalg.eigsh``: matrix-vector products, O(m^2) each, on a float32 copy)
#: instead of a dense eigendecomposition, which is O(m^3): 17-69 s at m = 4,600 on this
#: project's machine against 0.8 s. Below it the dense one is faster and exactly as before.
DENSE_EIGH_MAX = 1000


def spectral_labels(A, k: int, rng: np.random.Generator, *, symmetric: bool = False) -> np.ndarray:
    """Spectral clustering of Ng, Jordan & Weiss on affinity ``A`` (m, m). Returns (m,) labels.

    Embedding (:func:`spectral_embedding`), then k-means. With ``m <= k`` every item is its
    own cluster. At most O(m^2) time per matrix-vector product and O(m^2) memory (see
    :data:`DENSE_EIGH_MAX`). ``symmetric``: the caller knows ``A == A.T`` (spares a pass).
    """
    m = np.shape(A)[0]
    if m <= k:
        return np.arange(m)
    return kmeans(spectral_embedding(A, k, rng, symmetric=symmetric), k, rng)


def spectral_embedding(
    A, k: int, rng: np.random.Generator, *, symmetric: bool = False
) -> np.ndarray:
    """The ``k`` leading eigenvectors of ``D^-1/2 A D^-1/2`` (zero diagonal) of affinity
    ``A`` (m, m), ``m > k``, rows normalized to unit length: (m, k)."""
    m = np.shape(A)[0]
    if m > DENSE_EIGH_MAX:
        # drawn either way, so the restarts after this one draw what they always did
        v0 = rng.uniform(0.5, 1.0, m).astype(np.float32)
        grouped = grouped_embedding(A, k)
        if grouped is not None:
            return grouped
        from scipy.sparse.linalg import eigsh  # imported here: small fits never need it

        M = _normalized_affinity(A, symmetric)
        _, vecs = eigsh(M, k, which="LA", v0=v0)
        vecs = vecs.astype(np.float64)
    else:
        M = np.array(A, dtype=np.float64)
        np.fill_diagonal(M, 0.0)
        M += M.T  # numpy buffers the overlapping transpose
        M *= 0.5
        deg = M.sum(1, dtype=np.float64)
        inv = _inv_sqrt(deg)
        M *= inv[:, None]
        M *= inv[None, :]
        _, vecs = leading_eigh(M, k)  # scipy.linalg.eigh's driver, without importing it
    norms = np.linalg.norm(vecs, axis=1, keepdims=True)
    return vecs / np.where(norms > 0, norms, 1.0)


def grouped_embedding(A, k: int):
    """:func:`spectral_embedding` of a 0/1 affinity whose rows repeat, solved exactly on
    its distinct rows, or None when that does not apply.

    Items of one group (identical rows, hence identical columns when ``A`` is symmetric)
    are the blocks of ``A = P B P^T`` (``P`` the (m, g) membership, ``c`` the group sizes,
    ``b`` the diagonal of ``B``). ``M = D^-1/2 (A - diag A) D^-1/2`` maps the group-constant
    vectors onto themselves, where it is the (g, g) matrix ``N = E B E - diag(b / delta)``
    (``delta = B c - b`` the degrees, ``E = diag(sqrt(c / delta))``) in the basis ``P
    C^-1/2``; on the vectors summing to 0 in every group it is ``-b / delta``. When the
    ``k`` largest eigenvalues of ``N`` exceed every one of the latter, the ``k`` leading
    eigenvectors of ``M`` are ``P C^-1/2 Z`` (``Z`` those of ``N``), whose unit rows are the
    unit rows of ``Z``: one dense eigenproblem of g instead of ARPACK over m (the equality
    kernel of HACA's one-frame units on the paper's synthetic take: g = 19, m = 4,923).
    """
    A = np.asarray(A)
    if A.dtype not in (np.bool_, np.int8, np.uint8):
        return None
    ids = frame_ids(A, DENSE_EIGH_MAX)
    if ids is None:
        return None
    g = int(ids.max()) + 1
    if g <= k:
        return None
    reps = np.unique(ids, return_index=True)[1]
    R = A[reps].astype(np.float64)  # (g, m): one row per group
    B = R[:, reps]
    if not (np.array_equal(R, B[:, ids]) and np.array_equal(B, B.T)):
        return None  # columns do not follow the groups: A is not P B P^T
    c = np.bincount(ids, minlength=g).astype(np.float64)
    b = np.diag(B).copy()
    inv = _inv_sqrt(B @ c - b)
    e = np.sqrt(c) * inv
    N = e[:, None] * B * e[None, :]
    N[np.diag_indices(g)] -= b * inv * inv
    w, Z = np.linalg.eigh(N)
    outside = -(b * inv * inv)[c > 1]
    if outside.size and w[g - k] <= outside.max() + 1e-9:
        return None  # the k leading eigenvectors are not all group-constant
    Z = Z[:, g - k :]
    norms = np.linalg.norm(Z, axis=1, keepdims=True)
    return (Z / np.where(norms > 0, norms, 1.0))[ids]


def _inv_sqrt(deg):
    return np.where(deg > 0, 1.0 / np.sqrt(np.where(deg > 0, deg, 1.0)), 0.0)


def _normalized_affinity(A, symmetric: bool = False) -> np.ndarray:
    """``D^-1/2 S D^-1/2`` in float32 of ``S = (A + A.T) / 2`` with a zero diagonal: the
    matrix ARPACK multiplies, in three passes (``streamseg._kernels.affinity``), or in one
    pass over the rows of an integer ``A`` its caller knows to be symmetric (``S = A``, eq.
    10's similarity); the same to the bit as the numpy expression in ``tests/naive.py``."""
    A = np.asarray(A)
    if A.dtype == np.bool_:
        A = A.view(np.uint8)
    elif A.dtype not in (np.int8, np.uint8):  # a 0/1 kernel stays narrow: 1/8 of the reads
        A = A.astype(np.float64, copy=False)
    if symmetric and A.dtype != np.float64:  # neither its transpose nor halving needed
        A = np.ascontiguousarray(A)
        # integer degrees: exact in any order, so numpy's sum of the float32 copy's rows
        deg = A.sum(1, dtype=np.int64) - np.diagonal(A).astype(np.int64)
        inv = _inv_sqrt(deg.astype(np.float64)).astype(np.float32)
        return scaled_symmetric(A, inv, np.empty(A.shape, np.float32))
    M = symmetrized(np.ascontiguousarray(A), np.empty(A.shape, np.float32))
    inv = _inv_sqrt(M.sum(1, dtype=np.float64))  # numpy's own summation order
    scale_both(M, inv.astype(np.float32))
    return M


def random_tiling(n: int, wmin: int, wmax: int, rng: np.random.Generator):
    """Random (starts, ends) covering ``0..n`` with lengths uniform in [wmin, wmax].

    Keeps every length in range whenever ``n`` can be tiled that way; otherwise the last piece
    takes the remainder.
    """
    if wmin == wmax:  # one length, no draw (integers(w, w + 1) consumes nothing): the
        # loop's tiling and generator state without its n / w Python steps
        b = np.append(np.arange(0, max(n, 1), wmax, dtype=np.int64), n)
        return b[:-1].copy(), b[1:].copy()
    bounds = [0]
    pos = 0
    while n - pos > wmax:
        rest = n - pos
        hi = min(wmax, rest - wmin)
        w = int(rng.integers(wmin, hi + 1)) if hi >= wmin else min(wmax, rest - 1)
        pos += w
        bounds.append(pos)
    bounds.append(n)
    b = np.asarray(bounds, dtype=np.int64)
    return b[:-1].copy(), b[1:].copy()


def random_init(K, k: int, wmin: int, wmax: int, rng: np.random.Generator):
    """Random tiling labelled by spectral clustering of its segment DTAK matrix."""
    starts, ends = random_tiling(K.shape[0], wmin, wmax, rng)
    T = tiling_kernel(K, starts, ends)
    return starts, ends, spectral_labels(T, k, rng).astype(np.int64)


def tiling_kernel(K, starts, ends) -> np.ndarray:
    """(m, m) DTAKs between the segments of a tiling of ``K`` (n, n); of one-frame segments
    it is ``K`` itself (the DTAK of two single frames is their kernel value, exactly), in
    K's own dtype when the tiling is every frame (a 0/1 int8 kernel is not widened)."""
    if np.all(ends - starts == 1):
        if starts.shape[0] == K.shape[0]:  # every frame: K itself, no copy of (n, n)
            return K if K.dtype in (np.int8, np.float64) else np.asarray(K, np.float64)
        return np.asarray(K)[np.ix_(starts, starts)].astype(np.float64)
    return segment_kernel(K, starts, ends)


#: A random restart whose tiling has at most this many segments gets its own segment DTAK
#: matrix and eigenproblem (:func:`random_init`; a dense one of 500 takes ~20 ms); above it
#: the restarts of a fit share one embedding (:class:`RandomInits`). Sharing it below this
#: lost accuracy on noisy synthetic sequences (flat ACA, p_noise 0.3, 5 sequences: 0.745 ->
#: 0.683 at max_len 15, ``benchmarks/aca_synthetic.py``).
OWN_EMBEDDING_MAX = 500


class RandomInits:
    """The random initializations of one fit, sharing what is expensive in them.

    A tiling of at most :data:`OWN_EMBEDDING_MAX` segments is labelled on its own, as
    :func:`random_init` does. Above that, the first such call labels its tiling as
    :func:`random_init` does, and its embedding, spread over the frames (each frame takes its
    segment's row), is the only one: every later call embeds each segment of its own tiling
    as the normalized mean of its frames' rows, then runs k-means from its own seeds. A
    restart thus costs O(n k) instead of a DTAK matrix and an eigenproblem over its m
    segments, which at the fine level of HACA (one-frame segments) is every frame.
    """

    def __init__(self, K, wmin: int, wmax: int):
        self.K = K
        self.wmin, self.wmax = wmin, wmax
        self._first = None  # (starts, ends, T) of the first tiling
        self._frames = {}  # k -> (n + 1, k) cumulative frame embedding

    def __call__(self, k: int, rng: np.random.Generator):
        """``(starts, ends, labels)`` of one restart."""
        n = self.K.shape[0]
        starts, ends = random_tiling(n, self.wmin, self.wmax, rng)
        if starts.shape[0] <= k:  # every segment its own cluster, as spectral_labels
            return starts, ends, np.arange(starts.shape[0], dtype=np.int64)
        if starts.shape[0] <= OWN_EMBEDDING_MAX:  # cheap: as random_init, exactly
            T = tiling_kernel(self.K, starts, ends)
            return starts, ends, spectral_labels(T, k, rng).astype(np.int64)
        if self._first is None:
            self._first = starts, ends, tiling_kernel(self.K, starts, ends)
        s0, e0, T = self._first
        if k not in self._frames:
            emb = spectral_embedding(T, k, rng)
            cum = np.zeros((n + 1, k))
            np.cumsum(np.repeat(emb, e0 - s0, axis=0), axis=0, out=cum[1:])
            self._frames[k] = cum
            if starts is s0:  # the embedded tiling itself: its own rows
                return starts, ends, kmeans(emb, k, rng).astype(np.int64)
        cum = self._frames[k]
        emb = (cum[ends] - cum[starts]) / (ends - starts)[:, None]
        norms = np.linalg.norm(emb, axis=1, keepdims=True)
        emb /= np.where(norms > 0, norms, 1.0)
        return starts, ends, kmeans(emb, k, rng).astype(np.int64)


def propagated_similarity(frame_classes, wmax: int) -> np.ndarray:
    """Eq. 10: (n, n) boolean frame similarity from per-frame classes, propagated along time.

    ``kappa[i, j] = 1`` for frames of one class; then for every pair ``(i1, i2)`` of the same
    class whose frames ``d`` steps earlier (``1 <= d <= wmax``) also share a class, the
    pairs ``(i1, i1-d)``, ``(i2, i2-d)``, ``(i1, i2-d)``, ``(i1-d, i2)`` become 1 (both orders).
    In ``streamseg._kernels.affinity.propagated``: only the linked pairs are visited.
    """
    c = np.asarray(frame_classes)
    n = c.shape[0]
    codes = np.unique(c, return_inverse=True)[1].reshape(n).astype(np.int64)
    return propagated(codes, int(wmax), np.zeros((n, n), dtype=np.bool_))


def runs_to_segments(frame_labels, wmin: int, wmax: int):
    """Turn per-frame labels into segments within [wmin, wmax] (section 4.2).

    Runs of one label longer than ``wmax`` are divided into equal pieces; runs shorter than
    ``wmin`` are merged into the preceding segment (the first into the next). Each segment takes
    its most frequent frame label.
    """
    lab = np.asarray(frame_labels)
    n = lab.shape[0]
    cuts = np.flatnonzero(np.diff(lab) != 0) + 1
    b = np.concatenate([[0], cuts, [n]])
    pieces = []
    for s, e in zip(b[:-1], b[1:], strict=True):
        parts = int(np.ceil((e - s) / wmax))
        edges = np.linspace(s, e, parts + 1).round().astype(np.int64)
        pieces.extend(zip(edges[:-1], edges[1:], strict=True))
    merged: list[list[int]] = []
    for s, e in pieces:
        if merged and (e - s < wmin or merged[-1][1] - merged[-1][0] < wmin):
            merged[-1][1] = e  # may exceed wmax: the first DP step re-cuts it
        else:
            merged.append([s, e])
    starts = np.asarray([s for s, _ in merged], dtype=np.int64)
    ends = np.asarray([e for _, e in merged], dtype=np.int64)
    labels = np.asarray([np.bincount(lab[s:e]).argmax() for s, e in merged], dtype=np.int64)
    return starts, ends, labels


def skip_propagated_draws(rng: np.random.Generator, n: int, k: int) -> None:
    """Draw from ``rng`` what :func:`propagated_init` of ``n`` units into ``k`` clusters
    draws when no k-means++ step meets an all-zero distance (the usual case): the ARPACK
    start vector, k-means++'s first centre and one uniform per later centre. A caller that
    runs later restarts from the generator so advanced, in parallel with the propagated one,
    checks the real generator's state afterwards (:meth:`ACAEngine.fit`)."""
    if n <= k:
        return
    if n > DENSE_EIGH_MAX:
        rng.uniform(0.5, 1.0, n)
    rng.integers(n)
    for _ in range(1, k):
        rng.random()


def propagated_init(frame_classes, k: int, wmin: int, wmax: int, rng: np.random.Generator):
    """Section 4.2 initialization: spectral clustering of the eq. 10 similarity, then lengths
    forced into [wmin, wmax]. ``frame_classes``: (n,) k-means class of each frame."""
    S = propagated_similarity(frame_classes, wmax)
    labels = spectral_labels(S, k, rng, symmetric=True)  # by construction
    starts, ends, seg_labels = runs_to_segments(labels, wmin, wmax)
    return starts, ends, seg_labels
