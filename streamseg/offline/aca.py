"""Aligned Cluster Analysis (Zhou, De la Torre & Hodgins 2008): kernel k-means over
variable-length segments compared with DTAK, solved by coordinate descent whose segmentation
step is a dynamic programme.

Objective (eq. 5): ``J = sum_i dist_{c_i}(Y_i)`` with ``dist`` of eq. 3 on segment DTAKs. With
a unit-diagonal frame kernel every self-DTAK is 1, so ``J = m - sum_c h_c / n_c`` for the
final segmentation (m segments, ``h_c`` the sum of the cluster's segment DTAK block).

Decisions (see also :class:`ACA`):

* The DP admits only lengths in [min_len, max_len], as Algorithm 1 and eq. 9 of the paper do.
  The reference code admits 1..max_len (min_len only shapes the initialization); we keep the
  paper's constraint because min_len_frames is the user's granularity control and without it the DP
  is free to carve out one-frame segments that fit a centre well. Only when ``n`` frames
  cannot be tiled with lengths in range (e.g. ``n < min_len``) is the lower bound dropped to 1.
* An empty cluster is re-seeded with the segment farthest from its own centre (taken from a
  cluster with at least two segments). This strictly lowers the objective, like re-seeding in
  k-means, so the descent stays monotone.
* Coordinate descent stops when a DP step returns the segmentation it was given (or after
  ``max_iter`` steps); restarts keep the lowest objective (the first one on ties, so the
  answer does not depend on ``n_jobs``).

Speed: the DP step (``streamseg._kernels.aca``) costs O(n^2 max_len_frames) per iteration and
O(k n max_len_frames) memory besides the (n, n) frame kernel, as in section 3.5. For the 0/1
equality kernel it runs in exact int8 (int16 for long segments) arithmetic, and the kernel is
kept as int8. The cluster statistics, objective and re-seeding of a step are read off the
same candidate table (:func:`streamseg.offline.aca_descent.descend`), so a step builds no
segment DTAK matrix; with a 0/1 kernel, old segments of identical frames (a repeated motif
of symbols) are computed once and counted (exact integer sums: the same table). Random
restarts of a long tiling share one spectral embedding
(:class:`streamseg.offline.aca_init.RandomInits`). Restarts of a large problem run in
threads (``n_jobs``, :data:`THREADED_WORK`).
"""

from __future__ import annotations

import contextlib
import functools
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from streamseg.exceptions import ParameterError
from streamseg.offline.aca_descent import (  # noqa: F401  (NEG, dp_step, work_dtype: public here)
    NEG,
    descend,
    dp_kernel,
    dp_step,
    frame_ids,
    work_dtype,
)
from streamseg.offline.aca_init import RandomInits, kmeans, propagated_init, skip_propagated_draws
from streamseg.offline.dtak import KERNELS, _as_frames, frame_kernel
from streamseg.segments import Estimator

INITS = ("random", "propagated")
#: Restarts run in threads only when one DP step reads at least this many kernel cells
#: (``n^2 wmax``): below it (HACA on a reduced take: ~10^5) a descent takes about a
#: millisecond and starting and joining threads cost more than they save.
THREADED_WORK = 10_000_000


@functools.cache
def _blas_controller():
    """threadpoolctl's view of the loaded BLAS libraries, or None; found once per process
    (finding them scans every loaded library, which cost more than a small fit)."""
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # optional: without it BLAS keeps its own thread count
        return None
    return ThreadpoolController()


def single_threaded_blas():
    """Context limiting BLAS/LAPACK to one thread (threadpoolctl, when installed).

    ACA's LAPACK calls are small (spectral embedding of a few hundred segments); with a
    multi-threaded OpenBLAS on a busy machine they were 40x slower than single-threaded, and
    in the daemon the relabel worker must not grab every core.
    """
    controller = _blas_controller()
    if controller is None:
        return contextlib.nullcontext()
    return controller.limit(limits=1)


def available_cpus() -> int:
    """CPUs this process may run on (its affinity where the OS tells it)."""
    import os

    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def feasible_min_len(n: int, wmin: int, wmax: int) -> int:
    """``wmin`` if ``n`` frames can be tiled by lengths in [wmin, wmax], else 1."""
    lo = -(-n // wmax)
    hi = n // wmin
    return wmin if lo <= hi else 1


def cluster_stats(T: np.ndarray, labels: np.ndarray, k: int):
    """Per-cluster segment counts ``n_c`` (k,) and ``h_c / n_c**2`` (k,) from the (m, m) DTAKs.

    Here and below only within-cluster entries of ``T`` are read.
    """
    n_c = np.bincount(labels, minlength=k).astype(np.float64)
    const = np.zeros(k)
    for c in range(k):
        if n_c[c] > 0:
            idx = np.flatnonzero(labels == c)
            const[c] = T[np.ix_(idx, idx)].sum() / n_c[c] ** 2
    return n_c, const


def objective(T: np.ndarray, labels: np.ndarray, k: int) -> float:
    """Eq. 5 for a segmentation whose (m, m) segment DTAK matrix is ``T``."""
    n_c, const = cluster_stats(T, labels, k)
    dist = (
        np.diag(T)
        - 2.0
        * np.array([T[i, labels == labels[i]].sum() / n_c[labels[i]] for i in range(len(labels))])
        + const[labels]
    )
    return float(dist.sum())


def reseed_empty(T: np.ndarray, labels: np.ndarray, k: int) -> np.ndarray:
    """Give every empty cluster the segment farthest from its centre (see module docstring)."""
    labels = labels.copy()
    while True:
        counts = np.bincount(labels, minlength=k)
        empty = np.flatnonzero(counts == 0)
        movable = counts[labels] >= 2
        if empty.size == 0 or not movable.any():
            return labels
        n_c, const = cluster_stats(T, labels, k)
        own = np.array([T[i, labels == labels[i]].sum() for i in range(len(labels))])
        dist = np.diag(T) - 2.0 * own / n_c[labels] + const[labels]
        dist[~movable] = -np.inf
        labels[int(np.argmax(dist))] = empty[0]


class ACAEngine(Estimator):
    """Aligned Cluster Analysis of one sequence of frames, as the paper states it: lengths in
    frames and a given number of clusters (the engine :class:`streamseg.offline.ACA` and the
    relabeller run; :class:`streamseg.offline.ACA` takes an ``ACAConfig`` and ``fps``).

    Parameters
    ----------
    n_clusters : int
        Number of actions k.
    min_len_frames, max_len_frames : int
        Segment lengths in frames (of the sequence given to :meth:`fit`, before reduction).
    n_init : int
        Restarts; the one with the lowest objective is kept.
    max_iter : int
        Cap on coordinate-descent steps per restart.
    kernel : {"gaussian", "equality", "precomputed"}
        Frame kernel; with "precomputed" :meth:`fit` takes an (n, n) kernel with unit diagonal.
    sigma : float or None
        Gaussian bandwidth (None: ``streamseg.offline.dtak.default_sigma``).
    init : {"random", "propagated"} or list of (start, end, label)
        "random": random tilings labelled by spectral clustering of their segment DTAKs.
        "propagated": the first restart starts from the eq. 10 spectral initialization (frame
        classes by k-means into ``k_frame`` classes, or the reduction classes), the others
        are random. An explicit segmentation is used for the first restart (warm start).
    k_reduce : int or None
        Temporal reduction (section 4.1, :mod:`streamseg.offline.reduction`) into this many
        frame classes; None = no reduction.
    reduce_cap : int
        At most this many consecutive same-class frames become one reduced frame.
    k_frame : int
        Frame classes for the propagated initialization without reduction.
    n_jobs : int
        Threads running restarts in parallel (results do not depend on it); -1: one per
        CPU this process may use.
    random_state : int, numpy Generator or None

    Attributes
    ----------
    labels_ : (n_frames,) int64
    segments_ : list of (start, end, label)
        Half-open frame ranges covering the sequence.
    objective_ : float
        Eq. 5 of the kept restart (on the reduced sequence when reducing).
    restart_objectives_ : ndarray, shape (n_init,)
        Eq. 5 at the end of every restart; ``objective_`` is their minimum.
    n_iter_ : int
        Coordinate-descent steps of the kept restart.
    """

    def __init__(
        self,
        n_clusters,
        min_len_frames,
        max_len_frames,
        *,
        n_init=10,
        max_iter=50,
        kernel="gaussian",
        sigma=None,
        init="random",
        k_reduce=None,
        reduce_cap=20,
        k_frame=20,
        n_jobs=1,
        random_state=None,
    ):
        self.n_clusters = n_clusters
        self.min_len_frames = min_len_frames
        self.max_len_frames = max_len_frames
        self.n_init = n_init
        self.max_iter = max_iter
        self.kernel = kernel
        self.sigma = sigma
        self.init = init
        self.k_reduce = k_reduce
        self.reduce_cap = reduce_cap
        self.k_frame = k_frame
        self.n_jobs = n_jobs
        self.random_state = random_state

    def _validate(self):
        def posint(name, v, lo=1):
            if not (isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= lo):
                raise ParameterError(f"{name}={v!r} is invalid: expected an integer >= {lo}")

        posint("n_clusters", self.n_clusters)
        posint("min_len_frames", self.min_len_frames)
        posint("max_len_frames", self.max_len_frames)
        posint("n_init", self.n_init)
        posint("max_iter", self.max_iter)
        posint("reduce_cap", self.reduce_cap)
        posint("k_frame", self.k_frame)
        if self.n_jobs != -1:
            posint("n_jobs", self.n_jobs)
        if self.max_len_frames < self.min_len_frames:
            raise ParameterError(
                f"max_len_frames={self.max_len_frames!r} is invalid: expected >= "
                f"min_len_frames={self.min_len_frames}"
            )
        if self.kernel not in KERNELS + ("precomputed",):
            raise ParameterError(
                f"kernel={self.kernel!r} is invalid: expected one of {KERNELS + ('precomputed',)}"
            )
        if self.k_reduce is not None:
            posint("k_reduce", self.k_reduce)
            if self.kernel == "precomputed":
                raise ParameterError(
                    "k_reduce needs frames, not kernel='precomputed'; set k_reduce=None"
                )
        if not (isinstance(self.init, (list, tuple)) or self.init in INITS):
            raise ParameterError(
                f"init={self.init!r} is invalid: expected one of {INITS} "
                "or a list of (start, end, label)"
            )

    def fit(self, X, frame_classes=None):
        """Segment ``X``: (n_frames, d) features, or (n, n) kernel if kernel="precomputed".

        ``frame_classes`` (n,) optional ints: classes of the units for the propagated
        initialization (e.g. HACA's fine-level labels); default k-means of the frames.
        """
        from streamseg.offline.reduction import expand_labels, reduce_frames

        self._validate()
        rng = np.random.default_rng(self.random_state)
        if self.kernel == "precomputed":
            # a 0/1 kernel given as int8 (HACA's equality kernel) is kept: every pass over
            # (n, n) reads 1 byte a cell instead of 8
            K = np.asarray(X)
            K = np.ascontiguousarray(K, dtype=np.int8 if K.dtype == np.int8 else np.float64)
            if K.ndim != 2 or K.shape[0] != K.shape[1] or K.shape[0] == 0:
                raise ParameterError(f"precomputed kernel must be (n, n), got {K.shape}")
            if not np.allclose(np.diag(K), 1.0):
                raise ParameterError("precomputed kernel needs a unit diagonal (normalize it)")
            n = K.shape[0]
            runs = None
            classes = None if frame_classes is None else np.asarray(frame_classes)
        else:
            X = _as_frames(X)
            n = X.shape[0]
            runs = None
            classes = None
            if self.k_reduce is not None:
                Xr, runs, classes = reduce_frames(X, self.k_reduce, self.reduce_cap, rng)
            else:
                Xr = X
            K = np.ascontiguousarray(
                frame_kernel(Xr, kernel=self.kernel, sigma=self.sigma, binary_dtype=np.int8)
            )
        nr = K.shape[0]
        # Lengths are given in original frames; a reduced frame stands for n / nr of them.
        scale = nr / n
        wmax = max(1, int(round(self.max_len_frames * scale)))
        wmin = min(wmax, max(1, int(round(self.min_len_frames * scale))))
        wmin = feasible_min_len(nr, wmin, wmax)
        k = self.n_clusters
        # the equality kernel is 0/1 by construction; a precomputed one is checked
        binary = self.kernel == "equality" or (self.kernel == "precomputed" and _zero_one(K))
        K_dp = dp_kernel(K, binary)
        # a 0/1 kernel repeats frames (symbols): old segments of identical frames are
        # computed once in each DP step (exact); a float kernel's sums keep their order
        ids = frame_ids(K_dp) if binary else None
        shared = RandomInits(K, wmin, wmax)

        def initial(r, generator=rng):
            return self._initial(
                r, K, X if runs is None else Xr, classes, k, wmin, wmax, generator, runs, n, shared
            )

        def run(init):
            return descend(
                K, *init, k, wmin, wmax, self.max_iter, binary=binary, K_dp=K_dp, ids=ids
            )

        jobs = available_cpus() if self.n_jobs == -1 else self.n_jobs
        with single_threaded_blas():
            if jobs > 1 and self.n_init > 1 and nr * nr * wmax >= THREADED_WORK:
                # the kernels release the GIL: descents run in threads while this one draws
                # the next initializations (in order, from the one generator)
                with ThreadPoolExecutor(min(jobs, self.n_init)) as pool:
                    results = self._speculated(pool, run, initial, rng, classes, nr, k)
                    if results is None:
                        shared = RandomInits(K, wmin, wmax)  # none of the guessed draws
                        futures = [pool.submit(run, initial(r)) for r in range(self.n_init)]
                        results = [f.result() for f in futures]
            else:
                results = [run(initial(r)) for r in range(self.n_init)]
        best = None
        for res in results:  # first of the lowest objectives: same answer for any n_jobs
            if best is None or res[3] < best[3] - 1e-12:
                best = res
        starts, ends, labels, obj, it = best
        self._store(starts, ends, labels, runs, n, expand_labels)
        self.objective_ = float(obj)
        self.restart_objectives_ = np.array([res[3] for res in results], dtype=np.float64)
        self.n_iter_ = int(it)
        self.min_len_used_, self.max_len_used_ = int(wmin), int(wmax)
        return self

    def _speculated(self, pool, run, initial, rng, classes, nr, k):
        """Restarts when the first one is the propagated initialization of given unit
        classes (HACA's coarse level: an eigenproblem over every unit, the longest step of
        the fit): it runs in a worker thread while this one draws the others from a copy of
        the generator advanced past what it will draw (:func:`skip_propagated_draws`).
        The same results as in order, checked: the generator the first restart leaves must
        be the copy's starting state. None when that does not hold (the restarts are then
        drawn again in order) or the first restart is not of that kind."""
        import copy

        if self.init != "propagated" or classes is None:
            return None
        ahead = copy.deepcopy(rng)
        skip_propagated_draws(ahead, nr, k)
        expected = ahead.bit_generator.state
        first = pool.submit(lambda: (initial(0, rng), rng.bit_generator.state))
        later = [pool.submit(run, initial(r, ahead)) for r in range(1, self.n_init)]
        init0, state = first.result()
        if state != expected:
            for f in later:
                f.cancel()
            return None
        return [run(init0)] + [f.result() for f in later]

    def _initial(self, r, K, X, classes, k, wmin, wmax, rng, runs, n, shared):
        if isinstance(self.init, (list, tuple)) and r == 0:
            return _explicit_init(self.init, runs, n, K.shape[0], k)
        if self.init == "propagated" and r == 0:
            if classes is None:
                if self.kernel == "precomputed":
                    classes = np.arange(K.shape[0])
                else:
                    classes = kmeans(X, self.k_frame, rng)
            return propagated_init(classes, k, wmin, wmax, rng)
        return shared(k, rng)

    def _store(self, starts, ends, labels, runs, n, expand_labels):
        seg_lab = np.repeat(labels, ends - starts)
        frame = seg_lab if runs is None else expand_labels(seg_lab, runs, n)
        self.labels_ = frame.astype(np.int64)
        cuts = np.flatnonzero(np.diff(frame)) + 1
        if runs is not None:
            # keep cuts between reduced segments even when both sides share a label
            b = np.concatenate([[0], runs[1][ends[:-1] - 1]])
            cuts = np.union1d(cuts, b[1:])
        else:
            cuts = np.union1d(cuts, starts[1:])
        bounds = np.concatenate([[0], cuts, [n]]).astype(np.int64)
        self.segments_ = [
            (int(s), int(e), int(frame[s])) for s, e in zip(bounds[:-1], bounds[1:], strict=True)
        ]


def _zero_one(K) -> bool:
    """Whether every entry of ``K`` is 0 or 1 (int8: one pass over its bytes)."""
    if K.dtype == np.int8:
        return bool(np.all(K.view(np.uint8) <= 1))
    return bool(np.all((K == 0.0) | (K == 1.0)))


def _explicit_init(init, runs, n, nr, k):
    segs = sorted((int(s), int(e), int(lab)) for s, e, lab in init)
    if (
        not segs
        or segs[0][0] != 0
        or segs[-1][1] != n
        or any(a[1] != b[0] for a, b in zip(segs[:-1], segs[1:], strict=True))
    ):
        raise ParameterError(f"init segments must tile 0..{n} without gaps or overlaps")
    if runs is not None:
        # map frame bounds to reduced units: unit u covers frames runs[0][u]..runs[1][u]
        unit = np.searchsorted(runs[0], [s for s, _, _ in segs], side="right") - 1
        unit = np.unique(unit)
        starts = unit.astype(np.int64)
        ends = np.append(unit[1:], nr).astype(np.int64)
        labels = np.array([next(lab for s, e, lab in segs if s <= runs[0][u] < e) for u in unit])
    else:
        starts = np.array([s for s, _, _ in segs], dtype=np.int64)
        ends = np.array([e for _, e, _ in segs], dtype=np.int64)
        labels = np.array([lab for _, _, lab in segs], dtype=np.int64)
    distinct, labels = np.unique(labels, return_inverse=True)
    if distinct.size > k:
        raise ParameterError(
            f"init has {distinct.size} distinct labels; expected at most n_clusters={k}"
        )
    return starts, ends, labels.astype(np.int64)
