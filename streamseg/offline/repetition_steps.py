"""The steps of Wang et al. 2015, section 4, as plain functions on arrays.

Frequencies are handled in *cycles per sequence* (the DFT bin unit the paper uses: "the power
at the frequency six") and converted to Hz only for reporting and filter design.
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.cluster.vq import kmeans2
from scipy.signal import butter, detrend, sosfiltfilt

from streamseg.exceptions import ParameterError

__all__ = ["adaptive_kmeans", "bandpass", "candidate_points", "kmeans_cost", "merge_same_phase",
           "power_spectrum", "primary_frequency", "select_group", "select_parameters",
           "to_repetitions"]


def power_spectrum(X: np.ndarray, pad: int = 4):
    """Per-parameter power spectra of linearly detrended trajectories.

    Parameters
    ----------
    X : ndarray, shape (n_frames, n_params)
    pad : int
        Zero-padding factor (the DFT has ``pad * n_frames`` points) for a finer frequency grid.

    Returns
    -------
    cycles : ndarray, shape (n_freq,)
        Frequency of each bin in cycles per sequence (``n_frames`` frames).
    power : ndarray, shape (n_freq, n_params)
        ``|F|^2 / n^2``: amplitudes normalised by the length, so sequences of any length and
        parameters in the same unit (radians) are comparable.
    """
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2 or X.shape[0] < 4:
        raise ParameterError(f"X must be (n_frames >= 4, n_params); got shape {X.shape}")
    n = X.shape[0]
    n_fft = int(pad) * n
    F = np.fft.rfft(detrend(X, axis=0), n=n_fft, axis=0)
    cycles = np.arange(F.shape[0]) * n / n_fft
    return cycles, (np.abs(F) / n) ** 2


def primary_frequency(cycles, power, *, min_cycles=2.0, max_cycles=None):
    """Eq. 9: the nonzero frequency with the largest power summed over parameters.

    Parameters
    ----------
    cycles : ndarray, shape (n_freq,)
    power : ndarray, shape (n_freq, n_params)
    min_cycles : float
        Lowest admissible frequency: a repetitive sequence holds at least this many cycles
        (excludes the slow drift a detrend leaves at the lowest bins).
    max_cycles : float, optional
        Highest admissible frequency.

    Returns
    -------
    index : int
        Bin of the primary frequency.
    """
    total = power.sum(axis=1)
    ok = cycles >= min_cycles
    if max_cycles is not None:
        ok &= cycles <= max_cycles
    if not ok.any():
        raise ParameterError(
            f"no frequency between min_cycles={min_cycles} and max_cycles={max_cycles} cycles "
            f"per sequence; the sequence is too short for repetitions (use a longer one)")
    idx = np.flatnonzero(ok)
    return int(idx[np.argmax(total[idx])])


def select_parameters(power_at_primary: np.ndarray, threshold: float = 0.9) -> np.ndarray:
    """Top-M parameters whose share of the power at the primary frequency reaches ``threshold``.

    Parameters
    ----------
    power_at_primary : ndarray, shape (n_params,)
    threshold : float in (0, 1]

    Returns
    -------
    ndarray of int, shape (M,)
        Parameter indices, strongest first.
    """
    p = np.asarray(power_at_primary, dtype=np.float64)
    order = np.argsort(-p, kind="stable")
    total = p.sum()
    if total <= 0:
        return order[:1]
    share = np.cumsum(p[order]) / total
    m = int(np.searchsorted(share, threshold - 1e-12)) + 1
    return order[: min(m, p.size)]


def bandpass(X, fps, low_hz, high_hz, order=2):
    """Zero-phase Butterworth band-pass (scipy ``sosfiltfilt``) along axis 0.

    Parameters
    ----------
    X : ndarray, shape (n_frames, n_params)
    fps, low_hz, high_hz : float
        ``0 < low_hz < high_hz < fps / 2``; ``low_hz <= 0`` gives a low-pass.
    order : int

    Returns
    -------
    ndarray, shape (n_frames, n_params)
    """
    nyq = 0.5 * fps
    high = min(high_hz, 0.95 * nyq)
    if low_hz > 0:
        sos = butter(order, [low_hz, high], btype="bandpass", fs=fps, output="sos")
    else:
        sos = butter(order, high, btype="lowpass", fs=fps, output="sos")
    X = detrend(np.asarray(X, dtype=np.float64), axis=0)
    padlen = min(X.shape[0] - 1, 3 * (2 * sos.shape[0] + 1) * 4)
    return sosfiltfilt(sos, X, axis=0, padlen=padlen)


def candidate_points(speed2: np.ndarray, window: int, step: int | None = None) -> np.ndarray:
    """Eq. 10: frames minimising the squared velocity sum in overlapping sliding windows.

    A window's minimum counts only when it is a local minimum of the whole curve, i.e. not
    on the window's edge (unless that edge is the sequence's); a minimum found by two
    overlapping windows is kept once.

    Parameters
    ----------
    speed2 : ndarray, shape (n_frames,)
        ``sum_m Delta_m(t)^2``.
    window : int
        Window length in frames (>= 3).
    step : int, optional
        Hop between windows; default half a window (50 % overlap).

    Returns
    -------
    ndarray of int, sorted
    """
    v = np.asarray(speed2, dtype=np.float64)
    n = v.shape[0]
    window = int(window)
    if window < 3:
        raise ParameterError(f"window={window} is invalid: expected >= 3 frames")
    step = max(1, window // 2 if step is None else int(step))
    found = set()
    for t1 in range(0, max(n - window, 0) + step, step):
        t2 = min(t1 + window, n)
        if t2 - t1 < 3:
            break
        t = t1 + int(np.argmin(v[t1:t2]))
        if (t > t1 or t1 == 0) and (t < t2 - 1 or t2 == n):
            found.add(t)
    return np.array(sorted(found), dtype=np.int64)


def kmeans_cost(V, labels, centers):
    """Eq. 11 + eq. 12 with lambda = N / K^2 (eq. 13).

    Returns
    -------
    cost, j_intra, j_inter : float
    """
    K, N = centers.shape[0], V.shape[0]
    j_intra = float(np.sum((V - centers[labels]) ** 2))
    diff = centers[:, None, :] - centers[None, :, :]
    j_inter = float(np.sum(diff**2))
    return j_intra + N / K**2 * j_inter, j_intra, j_inter


def adaptive_kmeans(V, k_max=10, restarts=5, seed=0):
    """Eq. 13: k-means for K = 2..k_max, keeping the K of least intra + lambda * inter cost.

    Parameters
    ----------
    V : ndarray, shape (N, M)
        Selected parameters at the candidate points.
    k_max : int
    restarts : int
        k-means++ initialisations per K; the one of least intra-class distance is kept.
    seed : int

    Returns
    -------
    labels : ndarray of int, shape (N,)
    k_star : int
    """
    V = np.asarray(V, dtype=np.float64)
    N = V.shape[0]
    if N < 3:
        return np.zeros(N, dtype=np.int64), 1
    rng = np.random.default_rng(seed)
    best = None
    for K in range(2, min(k_max, N - 1) + 1):
        fit = None
        for _ in range(restarts):
            with warnings.catch_warnings():  # an empty cluster is handled just below
                warnings.simplefilter("ignore", UserWarning)
                centers, labels = kmeans2(V, K, minit="++", seed=rng)
            used = np.unique(labels)
            if used.size < K:  # an empty cluster: recompute with the clusters that exist
                labels = np.searchsorted(used, labels)
                centers = centers[used]
            inertia = float(np.sum((V - centers[labels]) ** 2))
            if fit is None or inertia < fit[0]:
                fit = (inertia, labels, centers)
        cost = kmeans_cost(V, fit[1], fit[2])[0]
        if best is None or cost < best[0]:
            best = (cost, fit[1], fit[2].shape[0])
    return best[1].astype(np.int64), int(best[2])


def merge_same_phase(P, labels, max_distance=0.6):
    """Merge clusters whose mean phase vectors are close (single linkage).

    Eq. 13 divides lambda by K^2, so it readily splits one phase of the movement into
    clusters that differ only by when they occur (early vs late repetitions); eq. 14 would
    then see each part span only part of the sequence. Clusters whose centres are closer than
    ``max_distance`` (root-mean-square over parameters of cos(phase) differences; opposite
    phases are ~2 apart; 0.6 is about 50 degrees) are one phase.

    Parameters
    ----------
    P : ndarray, shape (N, M)
        cos(phase) of the selected parameters at the candidates.
    labels : ndarray of int, shape (N,)
    max_distance : float

    Returns
    -------
    ndarray of int, shape (N,)
        Labels 0..G-1 after merging.
    """
    labels = np.asarray(labels)
    if labels.size == 0:
        return labels.astype(np.int64)
    ks = np.unique(labels)
    C = np.array([P[labels == k].mean(axis=0) for k in ks])
    D = np.linalg.norm(C[:, None] - C[None], axis=2) / np.sqrt(P.shape[1])
    root = list(range(len(ks)))

    def find(i):
        while root[i] != i:
            i = root[i]
        return i

    for i in range(len(ks)):
        for j in range(i + 1, len(ks)):
            if D[i, j] < max_distance:
                root[find(j)] = find(i)
    group = np.array([find(i) for i in range(len(ks))])
    _, new = np.unique(group, return_inverse=True)
    return new[np.searchsorted(ks, labels)].astype(np.int64)


def group_span(points, n_frames, radius):
    """Eq. 14's phi: frames within ``radius`` of any point of the group."""
    covered = np.zeros(n_frames, dtype=bool)
    r = int(np.floor(radius))
    for p in np.asarray(points, dtype=np.int64):
        covered[max(0, p - r): min(n_frames, p + r + 1)] = True
    return int(covered.sum())


def select_group(points, labels, n_frames, period, rest_distance=None, tie_tolerance=0.05):
    """Eq. 14: the group of candidates spanning the most frames (radius = one period).

    Parameters
    ----------
    points : ndarray of int, shape (N,)
    labels : ndarray of int, shape (N,)
    n_frames : int
    period : float
        psi / omega_p: frames per cycle.
    rest_distance : ndarray, shape (K,), optional
        Distance of each group's mean pose to the pose at the sequence's ends. With a radius of
        a whole period, groups holding one point per cycle all span (nearly) the whole
        sequence; among the groups within ``tie_tolerance`` of the largest span the one
        closest to the rest pose wins (the phase where the subject starts and stops).
    tie_tolerance : float

    Returns
    -------
    int
        The chosen label.
    """
    ks = np.unique(labels)
    spans = np.array([group_span(points[labels == k], n_frames, period) for k in ks])
    tied = spans >= (1.0 - tie_tolerance) * spans.max()
    if rest_distance is None or tied.sum() == 1:
        return int(ks[np.argmax(spans)])
    d = np.where(tied, np.asarray(rest_distance)[ks], np.inf)
    return int(ks[np.argmin(d)])


def to_repetitions(points, n_frames, period, edge_fraction=0.5, activity=None,
                   min_activity=0.1, merge_edges=False):
    """Repetitions between consecutive boundary points, with missed boundaries inferred.

    Points closer than half a period are merged (the first kept). The local period is the
    median spacing of the points, each gap divided by its number of whole ``period`` s
    (``period`` itself when there are fewer than two points). A gap of ``g`` periods
    between two points holds ``round(g)`` repetitions of equal length (a boundary the detector
    missed is put back where the rhythm says). The stretch before the first point (after the
    last) reaches the sequence's start (end) and holds ``max(1, round(g))`` repetitions,
    counted only when ``g >= edge_fraction`` and, with ``activity`` given, when the stretch
    moves (mean activity at least ``min_activity`` times the mean between the first and last
    point): a still lead-in is not a repetition.

    Parameters
    ----------
    points : array-like of int
    n_frames : int
    period : float
        Frames per cycle from the primary frequency.
    edge_fraction : float
    activity : ndarray, shape (n_frames,), optional
        E.g. eq. 10's squared velocity sum.
    min_activity : float
    merge_edges : bool
        A point closer than ``edge_fraction`` local periods to the sequence's start (end) is
        replaced by the start (end): the short stretch is the rest of the first (last)
        repetition instead of frames outside every repetition. That edge gap is then split
        by the rhythm like any other.

    Returns
    -------
    list of (int, int)
        0-based (start, end) with exclusive end.
    """
    pts = []
    for p in sorted(int(p) for p in points):
        if not pts or p - pts[-1] >= 0.5 * period:
            pts.append(p)
    if not pts:
        return []
    local = float(period)
    if len(pts) >= 2:
        # each gap counted in whole cycles of the spectral period, so a missed boundary
        # (a gap of two cycles) does not stretch the estimate
        gaps = np.diff(pts).astype(np.float64)
        local = float(np.median(gaps / np.maximum(1.0, np.round(gaps / period))))
    ref = None
    if activity is not None and len(pts) >= 2:
        ref = float(np.mean(activity[pts[0]:pts[-1]]))

    def moving(a, b):
        return ref is None or b <= a or np.mean(activity[a:b]) >= min_activity * ref

    # The sequence is taken to start and end at repetition boundaries: a counted edge
    # stretch reaches the sequence's first (last) frame and is split like any gap below.
    bounds = list(pts)
    # With ``merge_edges`` a point closer than ``edge_fraction`` periods to the sequence's
    # start (end) is taken for that end itself, the stretch between them being the rest of
    # the first (last) repetition, not a repetition of its own nor frames outside every one.
    if pts[0] / local >= edge_fraction and moving(0, pts[0]):
        bounds.insert(0, 0)
    elif merge_edges and 0 < pts[0] / local < edge_fraction and len(pts) >= 2:
        bounds[0] = 0
    if (n_frames - pts[-1]) / local >= edge_fraction and moving(pts[-1], n_frames):
        bounds.append(int(n_frames))
    elif merge_edges and 0 < (n_frames - pts[-1]) / local < edge_fraction and len(pts) >= 2:
        bounds[-1] = int(n_frames)
    out = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        k = max(1, int(round((b - a) / local)))
        cuts = [int(round(a + j * (b - a) / k)) for j in range(k + 1)]
        out.extend(zip(cuts[:-1], cuts[1:]))
    return [(int(a), int(b)) for a, b in out]
