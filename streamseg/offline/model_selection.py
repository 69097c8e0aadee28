"""How many actions: (H)ACA for each candidate K, scored by the silhouette of its segments.

Nobody can tell a live stream how many actions it will hold, so :func:`fit_aca` finds K when
``ACAConfig.n_clusters`` is None: it fits the configured model for every K in ``[2,
config.k_max]`` and keeps the one whose labelling has the highest mean silhouette (Rousseeuw
1987) under the DTAK distance the method itself uses, ``d(a, b) = 2 - 2 DTAK(a, b)``, measured
on equal pieces of half the longest segment (:func:`piece_silhouette`). The silhouette needs no
threshold or penalty weight, so nothing in it is tuned on a recording. HACA's over-splits are
postural phases of one labelled action (standing then lying), as far apart under DTAK as two
actions, so no criterion tried recovers the labelled count; the alternatives measured and why
this one stays: ``docs/decisions.md`` (Labels, "The number of actions").

Windows where there is nothing to cluster give one segment of one label instead of an
exception: too few frames for two segments of ``min_len``, no finite frame, or a body that
does not move (every feature's standard deviation below :data:`STILL_RAD`). Frames with a
non-finite feature are left out of the fit and take the label of the frame before them (the
first ones, of the first finite frame).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from streamseg.config import ACAConfig
from streamseg.exceptions import ParameterError

#: A window whose every feature varies less than this (standard deviation, radians: 0.06
#: degrees) holds no motion to cluster: one segment, one label.
STILL_RAD = 1e-3
#: The silhouette's frame kernel is computed on at most this many (evenly spaced) frames.
SILHOUETTE_FRAMES = 1500


@dataclass
class Fitted:
    """The result of :func:`fit_aca`: frame labels and segments as ACA/HACA give them.

    Attributes
    ----------
    labels_ : (n_frames,) int64
    segments_ : list of (start, end, label), tiling the frames
    n_clusters_ : int
        K used (found or given); 1 for a window with nothing to cluster.
    scores_ : dict
        K -> mean segment silhouette, for every K tried (empty when K was given).
    objective_ : float
        The kept model's objective (0 for one segment).
    reason : str
        Why the window was not clustered ("" when it was).
    model : ACAEngine, HACAEngine or None
        The kept fitted engine (None for one segment).
    """

    labels_: np.ndarray
    segments_: list
    n_clusters_: int
    scores_: dict = field(default_factory=dict)
    objective_: float = 0.0
    reason: str = ""
    model: object = None


class PieceSilhouette:
    """Silhouettes of labellings of one window, measured on equal pieces of it.

    The frames are cut into pieces of ``piece`` frames every ``piece // 2`` and the pieces
    compared once by the DTAK distance ``2 - 2 DTAK``; :meth:`score` then labels each piece
    by its most frequent label. Equal pieces make every K comparable: the model's own
    segments, fewer and of any length, gave a noisier score (module docstring).

    Parameters
    ----------
    X : (n, d) float array
    piece : int, frames
    kernel, sigma : the frame kernel (:func:`streamseg.offline.dtak.frame_kernel`)
    """

    def __init__(self, X, piece: int, *, kernel: str = "gaussian", sigma=None):
        from streamseg.offline.dtak import frame_kernel, segment_dtak

        n = X.shape[0]
        self.piece = max(2, min(int(piece), n))
        self.starts = np.arange(0, n - self.piece + 1, max(1, self.piece // 2))
        stride = max(1, -(-n // SILHOUETTE_FRAMES))
        Kf = frame_kernel(X[::stride], kernel=kernel, sigma=sigma)
        m = Kf.shape[0]
        bounds = [
            (
                min(s // stride, m - 1),
                max(min(s // stride, m - 1) + 1, min((s + self.piece) // stride, m)),
            )
            for s in self.starts
        ]
        self.D = np.clip(2.0 - 2.0 * segment_dtak(Kf, bounds), 0.0, None)

    def score(self, labels) -> float:
        """Mean silhouette of the per-frame ``labels`` (n,); -1 with fewer than two labels
        (a single cluster has no silhouette)."""
        labels = np.asarray(labels)
        lab = np.array([np.bincount(labels[s : s + self.piece]).argmax() for s in self.starts])
        ids = np.unique(lab)
        if ids.size < 2:
            return -1.0
        sil = np.zeros(lab.size)
        for i in range(lab.size):
            own = lab == lab[i]
            own[i] = False
            if not own.any():
                continue  # a cluster of one piece: silhouette 0 (Rousseeuw's convention)
            a = self.D[i, own].mean()
            b = min(self.D[i, lab == c].mean() for c in ids if c != lab[i])
            sil[i] = (b - a) / max(a, b, 1e-12)
        return float(sil.mean())


def piece_silhouette(X, labels, piece: int, *, kernel: str = "gaussian", sigma=None) -> float:
    """:meth:`PieceSilhouette.score` of one labelling of ``X``."""
    return PieceSilhouette(X, piece, kernel=kernel, sigma=sigma).score(labels)


def _single(n: int, reason: str) -> Fitted:
    return Fitted(np.zeros(n, dtype=np.int64), [(0, n, 0)] if n else [], 1, reason=reason)


def model_from_config(config: ACAConfig, fps: float, n_jobs: int = 1):
    """Unfitted ACA or HACA engine for ``config`` with its second-based lengths at ``fps``; restarts
    in ``n_jobs`` threads (-1: one per CPU)."""
    from streamseg.offline.aca import ACAEngine
    from streamseg.offline.haca import HACAEngine

    def frames(seconds):
        return max(1, int(round(seconds * fps)))

    common = dict(
        n_init=config.n_init,
        max_iter=config.max_iter,
        kernel=config.kernel,
        sigma=config.sigma,
        k_reduce=config.k_reduce,
        reduce_cap=frames(config.reduce_cap),
        random_state=config.random_state,
        n_jobs=n_jobs,
    )
    if config.hierarchical:
        return HACAEngine(
            config.n_clusters,
            frames(config.min_len_s),
            frames(config.max_len_s),
            fine_clusters=config.fine_clusters,
            fine_min_len_frames=frames(config.fine_min_len_s),
            fine_max_len_frames=frames(config.fine_max_len_s),
            coarse_kernel=config.coarse_kernel,
            **common,
        )
    return ACAEngine(
        config.n_clusters,
        frames(config.min_len_s),
        frames(config.max_len_s),
        init=config.init,
        **common,
    )


def fit_aca(X, config: ACAConfig, fps: float, n_jobs: int = 1) -> Fitted:
    """Fit (H)ACA to ``X`` with ``config``; K found by segment silhouette when not given.

    Parameters
    ----------
    X : (n, d) array
        Feature frames; rows with a non-finite value are allowed (see module docstring).
    config : ACAConfig
        ``n_clusters`` None: K is found in ``[2, k_max]``.
    fps : float
        Frame rate converting the config's seconds to frames.
    n_jobs : int
        Threads running each fit's restarts (-1: one per CPU; the result does not depend
        on it). The daemon relabels with 1: its cores go to other streams.

    Returns
    -------
    Fitted
    """
    if not (np.isfinite(fps) and fps > 0):
        raise ParameterError(f"fps={fps!r} is invalid: expected a frame rate > 0")
    X = np.asarray(X, dtype=np.float64)
    if X.ndim != 2:
        raise ParameterError(f"features must be an (n, d) array, got shape {X.shape}")
    n = X.shape[0]
    ok = np.isfinite(X).all(axis=1)
    m = int(ok.sum())
    min_len = max(1, int(round(config.min_len_s * fps)))
    if m < 2 * min_len:
        return _single(n, f"{m} finite frames, fewer than two segments of min_len")
    Xf = X[ok] if m < n else X
    if float(Xf.std(axis=0).max()) < STILL_RAD:
        return _single(n, "no motion in the window")
    # every K each time: HACA's fine level is fitted once for all of them, so the search
    # costs about 1.5 fits (0.23 s against 0.16 s on 60 s of 120 Hz features); searching only
    # around the previous revision's K stuck streams whose actions accumulate at a low K
    ks = [config.n_clusters] if config.n_clusters is not None else list(range(2, config.k_max + 1))
    ks = [k for k in ks if k * min_len <= m] or [1]
    piece = max(2, int(round(config.max_len_s * fps / 2)))  # half the longest segment
    model = model_from_config(config, fps, n_jobs)
    if config.hierarchical:  # one fine level for every K
        fits = model.fit_each(Xf, ks)
    else:
        fits = [
            (k, model_from_config(replace(config, n_clusters=k), fps, n_jobs).fit(Xf)) for k in ks
        ]
    scores = {}
    if len(fits) > 1:
        sil = PieceSilhouette(Xf, piece, kernel=config.kernel, sigma=config.sigma)
        scores = {k: sil.score(m.labels_) for k, m in fits}
    best = max(fits, key=lambda f: scores.get(f[0], 0.0))  # the first of equal scores
    k, model = best
    labels = np.asarray(model.labels_, dtype=np.int64)
    if m < n:  # spread the labels of the finite frames over the frames left out
        idx = np.maximum.accumulate(np.where(ok, np.arange(n), -1))
        first = int(np.flatnonzero(ok)[0])
        idx[idx < 0] = first
        full = labels[np.cumsum(ok)[idx] - 1]
        labels = full
    return Fitted(
        labels, _runs(labels, model.segments_, ok), k, scores, float(model.objective_), model=model
    )


def _runs(labels: np.ndarray, segments, ok: np.ndarray) -> list:
    """Segments in the frames of the whole window: the model's bounds (finite-frame indices)
    mapped back, so a boundary between two segments of one label survives."""
    n = labels.shape[0]
    if ok.all():
        return [(int(s), int(e), int(lab)) for s, e, lab in segments]
    where = np.flatnonzero(ok)
    starts = [0] + [int(where[s]) for s, _, _ in segments[1:]]
    ends = starts[1:] + [n]
    return [(a, b, int(labels[a])) for a, b in zip(starts, ends) if b > a]
