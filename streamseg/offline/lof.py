"""Offline LOF segmentation (Xing, Sun, Wei 2015), one small function per step.

Pipeline: 8 bone angles per frame (the paper; by default followed by the 9 bones' inclinations
from the up axis, ``LOFConfig.inclinations``, and by every feature's angular speed,
``LOFConfig.speed_max``) -> sliding windows -> per-angle histograms of
``bins`` equal bins over [0, pi] (normalized by the window's valid frames) -> one
``n_features * bins`` vector per window (the paper: 80) -> cosine distance ``1 - cos`` -> LOF
with ``k`` neighbours -> peaks of the LOF curve by Douglas-Peucker simplification and a robust
threshold -> cut at the centre of each peak window.

Decision: the paper simplifies the whole curve with Douglas-Peucker and takes its peaks, with no
stated threshold. Here a file is segmented with the decision the live detector makes
(:class:`streamseg.online.StreamingLOFSegmenter`, see :class:`streamseg.config.LOFConfig`): each
window is judged when ``delay_s`` of data after it exist, against the LOF curve of the bounded
buffer at that moment, its cut moved to the largest before/after histogram contrast and
confirmed by that contrast. One decision rule, so offline cuts equal the live ones (why not the
paper's whole-curve peaks of :func:`select_peaks`: ``docs/decisions.md``, Cuts). The
whole-recording curve (``lof_``) is still computed, for pictures and as the reference the
incremental LOF is tested against.

NaN policy (marker dropout): a frame with any NaN angle is skipped (counted in
``n_nan_frames_``) and contributes to no histogram; a window with fewer than
``config.min_valid * window`` valid frames is dropped from the LOF curve.
"""

from __future__ import annotations

import numpy as np

from streamseg._kernels.histogram import bin_frames, window_counts
from streamseg._kernels.lof import lof_batch
from streamseg._kernels.peaks import peak_windows, robust_threshold
from streamseg.config import LOFConfig
from streamseg.config.lof import feature_width, width_message
from streamseg.exceptions import ParameterError
from streamseg.segments import Estimator, segments_from_cuts


def lof_features(
    recording_or_angles, config: LOFConfig | None = None, n_features: int | None = None
) -> np.ndarray:
    """The LOF features of a Recording, or a given feature array validated.

    Parameters
    ----------
    recording_or_angles : Recording or array_like, shape (n_frames, n_features)
    config : LOFConfig or None
        ``config.inclinations`` selects the features (None: the default config).
    n_features : int or None
        Width an array must have; None: ``config.n_features``.

    Returns
    -------
    ndarray of float64, shape (n_frames, config.n_features)
        :func:`streamseg.skeleton.bone_angles` with ``inclinations=config.inclinations``:
        angles in [0, pi] (NaN rows allowed), then, with ``config.root_speed_max > 0``, the
        two root-speed columns of :class:`streamseg.online.root_speed.RootSpeed` (the
        recording's frame rate and up axis).
    """
    config = LOFConfig() if config is None else config
    d = feature_width(config, n_features)
    if hasattr(recording_or_angles, "positions") and hasattr(recording_or_angles, "skeleton"):
        rec = recording_or_angles
        return position_features(rec.positions, rec.skeleton, rec.fps, config)
    angles = np.asarray(recording_or_angles, dtype=np.float64)
    if angles.ndim != 2 or angles.shape[1] != d:
        raise ParameterError(width_message(angles.shape, d, config, n_features))
    return angles


def position_features(
    positions: np.ndarray,
    skeleton,
    fps: float,
    config: LOFConfig | None = None,
    up: str | None = None,
) -> np.ndarray:
    """The LOF features of joint positions: the bone features, then the root speeds.

    Parameters
    ----------
    positions : ndarray, shape (n_frames, n_joints, 3)
    skeleton : Skeleton or sequence of joint names
    fps : float
        Frame rate (the root speeds are per second).
    config : LOFConfig or None
        ``inclinations`` and ``root_speed_max`` select the columns (None: the default).
    up : str or None
        Up axis of the positions; None: the skeleton's.

    Returns
    -------
    ndarray of float64, shape (n_frames, config.n_features)
    """
    from streamseg.skeleton import bone_angles

    config = LOFConfig() if config is None else config
    angles = np.asarray(
        bone_angles(positions, skeleton, inclinations=config.inclinations, up=up), dtype=np.float64
    )
    if not config.root_columns:
        return angles
    from streamseg.online.root_speed import root_speed_columns

    root = root_speed_columns(positions, skeleton, fps, config, up=up)
    return np.ascontiguousarray(np.column_stack([angles, root]))


def frame_bins(angles: np.ndarray, bins: int):
    """Bin index of every angle and the validity (no NaN) of every frame.

    Returns
    -------
    fb : ndarray of int8, shape (n_frames, n_angles)
    valid : ndarray of uint8, shape (n_frames,)
    """
    angles = np.ascontiguousarray(angles, dtype=np.float64)
    n, a = angles.shape
    fb = np.empty((n, a), dtype=np.int8)
    valid = np.empty(n, dtype=np.uint8)
    bin_frames(angles, bins, fb, valid)
    return fb, valid


def window_histograms(angles: np.ndarray, window: int, step: int, bins: int, min_valid: int = 1):
    """Histogram count vectors of the sliding windows ``[w*step, w*step + window)``.

    Parameters
    ----------
    angles : ndarray, shape (n_frames, n_angles)
    window, step, bins, min_valid : int

    Returns
    -------
    counts : ndarray of float64, shape (m, n_angles * bins)
        Integer counts of the kept windows (angle-major: ``a * bins + b``).
    centres : ndarray of int64, shape (m,)
        Centre frame ``start + window // 2`` of each kept window.
    n_valid : ndarray of int64, shape (m,)
        Valid (non-NaN) frames of each kept window; ``counts / n_valid`` are the normalized
        histograms, each angle's summing to 1.
    """
    fb, valid = frame_bins(angles, bins)
    counts, n_valid = window_counts(fb, valid, bins, window, step)
    keep = n_valid >= min_valid
    centres = np.arange(counts.shape[0], dtype=np.int64) * step + window // 2
    return counts[keep], centres[keep], n_valid[keep]


def normalized(counts: np.ndarray, n_valid: np.ndarray) -> np.ndarray:
    """Histograms normalized by the window's valid frames, shape as ``counts``."""
    return counts / np.maximum(n_valid, 1)[:, None]


def lof_scores(vectors: np.ndarray, k: int, centres=None, exclusion: int = 0) -> np.ndarray:
    """LOF of each window vector with cosine distance.

    With ``exclusion == 0`` this equals scikit-learn's
    ``-LocalOutlierFactor(n_neighbors=k, metric="cosine").fit(vectors).negative_outlier_factor_``.

    Parameters
    ----------
    vectors : ndarray, shape (m, d)
    k : int
    centres : ndarray of int, shape (m,), optional
        Window times (frames); needed when ``exclusion > 0``.
    exclusion : int
        Windows whose centres are closer than this many frames are not neighbours.

    Returns
    -------
    ndarray of float64, shape (m,)
    """
    x = np.ascontiguousarray(vectors, dtype=np.float64)
    if centres is None:
        if exclusion > 0:
            raise ParameterError("lof_scores(exclusion > 0) needs the window centres")
        centres = np.arange(x.shape[0], dtype=np.int64)
    return lof_batch(x, int(k), np.ascontiguousarray(centres, dtype=np.int64), int(exclusion))[0]


def select_peaks(curve: np.ndarray, delay: int, config: LOFConfig, min_gap: int) -> np.ndarray:
    """Window indices of the cut peaks of a LOF curve (see :func:`peak_windows`)."""
    return peak_windows(
        np.ascontiguousarray(curve, dtype=np.float64),
        int(delay),
        config.dp_tolerance,
        config.threshold_mads,
        config.min_score,
        int(min_gap),
    )


class LOFSegmenter(Estimator):
    """Offline cut detection: LOF over sliding-window histograms of bone angles.

    Parameters
    ----------
    config : LOFConfig
    fps : float
        Frame rate, converting the config's seconds to frames.
    n_features : int or None
        Columns of a feature array given to :meth:`fit`; None: ``config.n_features``.

    Attributes
    ----------
    n_frames_ : int
    n_nan_frames_ : int
    counts_ : ndarray, shape (m, columns * bins), window count vectors; ``columns`` is
        ``config.histogram_columns(n_features)``: the features and, with ``speed_max > 0``
        (the default), their angular speeds
    vectors_ : ndarray, shape (m, columns * bins), normalized histograms
    centres_ : ndarray of int64, shape (m,), window centre frames
    lof_ : ndarray, shape (m,), the LOF curve of the whole recording (for inspection)
    threshold_ : float or None, the adaptive threshold of that whole curve (None with
        ``peak_rule = "paper"``: every peak vertex counts)
    cuts_ : ndarray of int64, cut frames: the live detector's decisions over the file
    scores_ : ndarray of float64, the LOF of each cut's window when it was decided
    decided_at_ : ndarray of int64, the frame at which each cut was decided
    segments_ : list of Segment, the segments between the cuts (labels 0, 1, ...);
        :meth:`predict` returns them
    """

    def __init__(
        self, config: LOFConfig | None = None, fps: float = 120.0, n_features: int | None = None
    ):
        self.config = LOFConfig() if config is None else config
        if not (np.isscalar(fps) and np.isfinite(fps) and float(fps) > 0):
            raise ParameterError(f"fps={fps!r} is invalid: expected a frame rate > 0")
        self.fps = float(fps)
        feature_width(self.config, n_features)  # validates
        self.n_features = n_features
        self.geometry = self.config.frames(self.fps)

    def fit(self, recording_or_angles) -> LOFSegmenter:
        """Compute the LOF curve and its peaks.

        Parameters
        ----------
        recording_or_angles : Recording or array_like, shape (n_frames, config.n_features)
            See :func:`lof_features`.
        """
        g, c = self.geometry, self.config
        angles = lof_features(recording_or_angles, c, self.n_features)
        self.n_frames_ = int(angles.shape[0])
        self.n_nan_frames_ = int((~np.isfinite(angles)).any(axis=1).sum())
        from streamseg.online.speed_features import lof_columns

        # the histogrammed columns, as the streaming detector makes them (speeds appended)
        fb, valid = frame_bins(lof_columns(angles, c, self.fps), c.bins)
        counts, n_valid = window_counts(fb, valid, c.bins, g["window"], g["step"])
        keep = n_valid >= g["min_valid"]
        centres = (np.arange(counts.shape[0], dtype=np.int64) * g["step"] + g["window"] // 2)[keep]
        counts, n_valid = counts[keep], n_valid[keep]
        self.counts_ = counts
        self.vectors_ = normalized(counts, n_valid)
        self.centres_ = centres
        # counts, not normalized vectors: integer dot products make identical windows exactly
        # distance 0, and the streaming detector uses the same numbers (online == offline)
        self.lof_ = lof_scores(counts, c.k, centres, g["exclusion"])
        m = self.lof_.shape[0]
        thr = robust_threshold(self.lof_, m, c.threshold_mads, np.empty(max(m, 1)))
        self.threshold_ = None if c.peak_rule == "paper" else float(max(thr, c.min_score))
        from streamseg.online.events import final_cuts
        from streamseg.online.lof import StreamingLOFSegmenter

        det = StreamingLOFSegmenter(c, self.fps, n_features=angles.shape[1])
        # the final decisions (with two stages: the confirming stage's, the same as one stage's)
        events = final_cuts(det.learn_many(angles) + det.finish())
        self.cuts_ = np.array([e.frame for e in events], dtype=np.int64)
        self.scores_ = np.array([e.score for e in events], dtype=np.float64)
        self.decided_at_ = np.array([e.emitted_at for e in events], dtype=np.int64)
        self.segments_ = segments_from_cuts(self.cuts_, self.n_frames_)
        return self


def warmup() -> None:
    """Compile (or load from cache) the kernels of the live detector and of this offline
    path."""
    from streamseg.online.lof import warmup as warmup_live

    warmup_live()
    cfg = LOFConfig(window_s=0.1, step_s=0.05, k=2, buffer_s=0.5, delay_s=0.05)
    angles = np.random.default_rng(0).uniform(0, np.pi, (40, cfg.n_features))
    angles[5] = np.nan
    LOFSegmenter(cfg, fps=100.0).fit(angles).predict()
