"""Evaluation measures. Frames are 0-based; a cut at f means a new segment starts at frame f."""

from __future__ import annotations

import numpy as np

# --- cut precision / recall / F1, covering, latency ------------------------------------------


def cut_windows_from(true_cuts, tolerance=None, windows=None, margin: int = 0):
    """Acceptance window ``(lo, hi)`` (inclusive) of each true cut.

    Parameters
    ----------
    true_cuts : sequence of int, shape (n_true,)
    tolerance : int, optional
        Flat tolerance: ``(t - tolerance, t + tolerance)``.
    windows : sequence of (int, int), optional
        Per-boundary windows (e.g. from :func:`streamseg.evaluation.labels.cut_windows`); used
        instead of ``tolerance`` when given.
    margin : int
        Frames added on both sides of every window.

    Returns
    -------
    ndarray of int64, shape (n_true, 2)
    """
    t = np.asarray(true_cuts, dtype=np.int64).reshape(-1)
    if windows is not None:
        w = np.asarray(windows, dtype=np.int64).reshape(-1, 2)
        if w.shape[0] != t.shape[0]:
            raise ValueError(f"{w.shape[0]} windows for {t.shape[0]} true cuts; give one each")
        w = np.column_stack([np.minimum(w[:, 0], t), np.maximum(w[:, 1], t)])
    elif tolerance is not None:
        w = np.column_stack([t - int(tolerance), t + int(tolerance)])
    else:
        raise ValueError("give tolerance (frames) or windows [(lo, hi), ...]")
    return w + np.array([-int(margin), int(margin)], dtype=np.int64)


def match_cuts(pred, true_cuts, tolerance=None, windows=None, margin: int = 0):
    """Maximum one-to-one matching of predicted to true cuts within acceptance windows.

    A prediction ``p`` may match true cut ``i`` when ``lo_i <= p <= hi_i``; each true cut and
    each prediction is matched at most once. Predictions are taken in time order and given to
    the open window that closes first, which maximizes the number of matches for intervals.

    Returns
    -------
    list of (int, int)
        ``(pred_index, true_index)`` pairs, indices into the sorted inputs.
    """
    p = np.sort(np.asarray(pred, dtype=np.int64).reshape(-1))
    w = cut_windows_from(true_cuts, tolerance, windows, margin)
    used = np.zeros(w.shape[0], dtype=bool)
    pairs = []
    for i, f in enumerate(p):
        ok = np.flatnonzero(~used & (w[:, 0] <= f) & (f <= w[:, 1]))
        if ok.size:
            j = ok[np.argmin(w[ok, 1])]
            used[j] = True
            pairs.append((i, int(j)))
    return pairs


def cut_scores(pred, true_cuts, tolerance=None, windows=None, margin: int = 0) -> dict:
    """Precision, recall and F1 of predicted cuts (see :func:`match_cuts`).

    Empty inputs follow the usual conventions: precision is 1 with no predictions, recall is
    1 with no true cuts, F1 is 0 when precision + recall is 0.

    Returns
    -------
    dict with ``precision``, ``recall``, ``f1``, ``tp``, ``n_pred``, ``n_true``
    """
    n_pred = int(np.size(pred))
    n_true = int(np.size(true_cuts))
    tp = len(match_cuts(pred, true_cuts, tolerance, windows, margin))
    precision = tp / n_pred if n_pred else 1.0
    recall = tp / n_true if n_true else 1.0
    f1 = 2 * precision * recall / (precision + recall) if precision + recall > 0 else 0.0
    return dict(precision=precision, recall=recall, f1=f1, tp=tp, n_pred=n_pred, n_true=n_true)


def _segments(cuts, n_frames: int) -> np.ndarray:
    c = np.unique(np.asarray(cuts, dtype=np.int64).reshape(-1))
    c = c[(c > 0) & (c < n_frames)]
    b = np.concatenate([[0], c, [n_frames]])
    return np.column_stack([b[:-1], b[1:]])


def covering(pred, true_cuts, n_frames: int) -> float:
    """Covering of the true segmentation by the predicted one (Arbelaez et al. 2011).

    ``C = (1 / n) * sum over true segments A of |A| * max over predicted segments B of
    |A & B| / |A | B|``; 1 for a perfect segmentation. Segments are ``[cut_i, cut_i+1)``.
    """
    if n_frames <= 0:
        raise ValueError(f"n_frames={n_frames}; expected > 0")
    ts, ps = _segments(true_cuts, n_frames), _segments(pred, n_frames)
    total = 0.0
    for a0, a1 in ts:
        inter = np.minimum(a1, ps[:, 1]) - np.maximum(a0, ps[:, 0])
        union = np.maximum(a1, ps[:, 1]) - np.minimum(a0, ps[:, 0])
        total += (a1 - a0) * float(np.max(np.where(inter > 0, inter / union, 0.0)))
    return total / n_frames


def latency_stats(latencies) -> dict:
    """Median, mean and max of latencies (frames); NaN for an empty list.

    Returns
    -------
    dict with ``n``, ``median``, ``mean``, ``max``
    """
    x = np.asarray(latencies, dtype=np.float64).reshape(-1)
    if x.size == 0:
        return dict(n=0, median=float("nan"), mean=float("nan"), max=float("nan"))
    return dict(n=int(x.size), median=float(np.median(x)), mean=float(x.mean()), max=float(x.max()))


# --- Hungarian-matched frame accuracy and confusion matrix -----------------------------------


def _frame_label_arrays(predicted, truth):
    from streamseg.exceptions import ParameterError

    p = np.asarray(predicted).ravel()
    t = np.asarray(truth).ravel()
    if p.shape != t.shape:
        raise ParameterError(
            f"predicted has {p.size} frames but truth has {t.size}; label the same frames"
        )
    return p, t


def frame_confusion(predicted, truth):
    """Confusion matrix of eq. 11 (Zhou et al. 2008) between two per-frame labelings.

    Parameters
    ----------
    predicted, truth : (n_frames,) arrays of hashable labels (ints or strings)

    Returns
    -------
    C : (k_pred, k_true) int64
        ``C[a, b]`` = number of frames labelled ``pred_labels[a]`` and ``true_labels[b]``.
    pred_labels, true_labels : ndarray
        The sorted distinct labels indexing the rows and columns.
    """
    p, t = _frame_label_arrays(predicted, truth)
    pl, pi = np.unique(p, return_inverse=True)
    tl, ti = np.unique(t, return_inverse=True)
    C = np.zeros((pl.size, tl.size), dtype=np.int64)
    np.add.at(C, (pi.ravel(), ti.ravel()), 1)
    return C, pl, tl


def matched_frame_accuracy(predicted, truth):
    """Fraction of frames whose predicted cluster maps to their true label under the one-to-one
    cluster-to-label matching that maximizes that fraction (Hungarian algorithm).

    Returns
    -------
    accuracy : float in [0, 1]
    mapping : dict
        predicted label -> matched true label (unmatched clusters are absent; they count as
        wrong, as do frames of unmatched true labels).
    """
    from scipy.optimize import linear_sum_assignment

    C, pl, tl = frame_confusion(predicted, truth)
    if C.size == 0:
        return 1.0, {}
    rows, cols = linear_sum_assignment(-C)
    acc = float(C[rows, cols].sum() / C.sum())
    return acc, {pl[r].item(): tl[c].item() for r, c in zip(rows, cols, strict=True)}


# --- repetition accuracy alpha and count error -----------------------------------------------


def matched_repetition_accuracy(found, truth) -> float:
    """Wang et al. 2015 eq. 15 (alpha) with the repetitions matched by overlap, not by order.

    Found and true repetitions are paired one to one to maximise the frames they share
    (Hungarian assignment); each pair scores ``1 - e / L`` (``e`` the difference of the
    lengths, ``L`` the true length), a pair that shares no frame 0, and the sum is divided by
    ``D``, the smaller of the two counts. A missed or an extra repetition thus costs no term
    but shifts none of the others (the paper pairs the i-th found with the i-th true one,
    which compares every repetition after a miss with the wrong one).

    Parameters
    ----------
    found, truth : sequence of (start, end)
        Segments, 0-based, end exclusive.

    Returns
    -------
    float
        alpha; 0.0 when either list is empty.
    """
    from scipy.optimize import linear_sum_assignment

    f = [(int(a), int(b)) for a, b in found]
    t = [(int(a), int(b)) for a, b in truth]
    if any(b <= a for a, b in t):
        from streamseg.exceptions import ParameterError

        raise ParameterError("every true repetition needs end > start")
    if not f or not t:
        return 0.0
    shared = np.array([[max(0, min(b, d) - max(a, c)) for c, d in t] for a, b in f], float)
    rows, cols = linear_sum_assignment(-shared)
    terms = [
        1.0 - abs((f[i][1] - f[i][0]) - (t[j][1] - t[j][0])) / (t[j][1] - t[j][0])
        if shared[i, j] > 0
        else 0.0
        for i, j in zip(rows, cols)
    ]
    return float(np.sum(terms) / min(len(f), len(t)))


def count_error(found_count: int, true_count: int) -> int:
    """Signed repetition-count error: found minus true (over-counting is positive)."""
    return int(found_count) - int(true_count)
