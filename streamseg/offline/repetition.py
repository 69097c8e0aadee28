"""Offline repetition counting: the live counter run over a whole recording.

One algorithm (:mod:`streamseg.online.repetition`), so every set's offline count is the count
the daemon reaches live on the same frames. A recording is cut into sets where the exercise
changes (a loop unlike the last), the person pauses, or the motion stops repeating; each set
is counted from two repetitions on.
"""

from __future__ import annotations

import numpy as np

from streamseg.config import RepetitionConfig
from streamseg.exceptions import ParameterError
from streamseg.offline.missing_frames import bad_frames
from streamseg.online.rep_pose import stream_features
from streamseg.online.repetition import RepetitionCounter
from streamseg.segments import Estimator, Segment

__all__ = ["RepetitionSegmenter", "set_summary"]

#: a limb joint lost in more than this share of the frames is left out, not bridged
LOST_SHARE = 0.5


def _lost(rec):
    """``(names, n_bad, unusable)`` of the joints the counter reads in ``rec``: the limb
    joints lost in more than :data:`LOST_SHARE` of the frames (the counter holds a joint lost
    long where it was last seen, :mod:`streamseg.online.rep_bridge`; one never seen is left
    out), the frames where another of them is lost, and whether no frame has the trunk and
    hips (nothing to count)."""
    from streamseg._kernels import rep_track as K
    from streamseg.exceptions import SkeletonError
    from streamseg.skeleton.names import POINTS, resolve

    P = np.asarray(rec.positions)
    if P.shape[0] == 0 or np.isfinite(P).all():
        return [], 0, False
    try:
        idx = resolve(list(rec.skeleton.names), K.POINTS, POINTS)
    except SkeletonError:
        return [], 0, False
    torso = [idx[K.POINTS.index(p)] for p in ("pelvis", "sternum", "l_hip", "r_hip")]
    unusable = not np.isfinite(P[:, torso]).all(axis=(1, 2)).any()
    lost = (~np.isfinite(P).all(axis=2)).mean(axis=0)
    out = [j for j in sorted(set(idx) - set(torso)) if lost[j] > LOST_SHARE]
    n_bad = int(bad_frames(P[:, sorted(set(idx) - set(out))]).sum())
    return [rec.skeleton.names[j] for j in out], n_bad, unusable


def set_summary(rep_set, fps: float, config: RepetitionConfig) -> dict:
    """Count, tempo and confidence of a :class:`~streamseg.online.repetition.RepSet`.

    Returns
    -------
    dict
        ``start``, ``end``, ``count``, ``tempo_min_s`` and ``tempo_max_s`` (seconds per
        repetition, shortest and longest), ``confidence`` (1 - the median dissimilarity of
        consecutive repetitions / ``max_dissimilarity``: 1 for identical repetitions, 0 at
        the limit of the repetitive test), ``end_reason`` and ``repetitions``; per
        repetition ``durations_s``, ``rom_deg`` (range of motion of ``rom_joint``, the joint
        that moves most, degrees; None without joints) and ``likeness``
        (:class:`~streamseg.online.repetition.RepEvent`).
    """
    durations = [(b - a) / fps for a, b in rep_set.repetitions]
    dis = [d for d in rep_set.dissimilarity if d is not None]
    conf = 1.0 - float(np.median(dis)) / config.max_dissimilarity if dis else 0.0
    return {
        "start": int(rep_set.start),
        "end": int(rep_set.end),
        "count": rep_set.count,
        "tempo_min_s": round(min(durations), 3),
        "tempo_max_s": round(max(durations), 3),
        "confidence": round(min(1.0, max(0.0, conf)), 3),
        "end_reason": rep_set.end_reason,
        "repetitions": [(int(a), int(b)) for a, b in rep_set.repetitions],
        "durations_s": [round(d, 3) for d in durations],
        "rom_joint": rep_set.rom_joint,
        "rom_deg": list(rep_set.rom_deg) or [None] * rep_set.count,
        "likeness": list(rep_set.likeness),
    }


class RepetitionSegmenter(Estimator):
    """Cut a recording into sets of repetitions and count each (offline).

    Parameters
    ----------
    config : RepetitionConfig, optional
    fps : float
        Frame rate of an array given to :meth:`fit` (a Recording brings its own).

    Attributes
    ----------
    sets_ : list of dict
        Per set, :func:`set_summary`.
    repetitions_ : list of (int, int)
        Every set's repetitions in order, 0-based, end exclusive.
    segments_ : list of Segment
        The repetitions as ``Segment(start, end, index)`` (what :meth:`predict` returns;
        they need not tile the take: frames outside every repetition are in none).
    labels_ : ndarray of int64, shape (n_frames,)
        Repetition index per frame, -1 outside every repetition.
    set_labels_ : ndarray of int64, shape (n_frames,)
        Set index per frame, -1 outside every set.
    count_ : int
        Repetitions over every set.
    repetitive_ : bool
        Whether any set was found (two or more alike repetitions in a row).
    reason_ : str
        Why not ("" when repetitive).
    features_ : ndarray, shape (n_frames, d)
        The pose features the counter analysed (before its low-pass): for a recording the
        28 of :func:`~streamseg.online.rep_pose.pose_features`, for an array the array.
    n_missing_frames_ : int
        Frames with a NaN or infinite value in a joint the counter reads (outside
        ``lost_joints_``). For a recording the
        counter bridges each lost joint as live (:mod:`streamseg.online.rep_bridge`: runs of
        up to 0.5 s interpolated, longer ones held where the joint was last seen); feature
        rows are interpolated from the good rows around them
        (:mod:`streamseg.offline.missing_frames`).
    lost_joints_ : list of str
        Limb joints lost in more than half of the frames (held where last seen, or, never
        seen, left out: the bones they end are still,
        :func:`~streamseg._kernels.rep_track.pose_features`); the other body parts count.
    n_frames_ : int
    fps_ : float
    """

    def __init__(self, config: RepetitionConfig | None = None, fps: float = 120.0):
        self.config = config or RepetitionConfig()
        if not (np.isscalar(fps) and float(fps) > 0):
            raise ParameterError(
                f"fps={fps!r} is invalid: expected the frame rate (> 0) of the arrays given to fit"
            )
        self.fps = float(fps)

    def fit(self, X) -> RepetitionSegmenter:
        """Count a recording (joint positions) or an array of pose features.

        Parameters
        ----------
        X : Recording or ndarray, shape (n_frames, d)
            A recording with joint names any skeleton map knows (its own frame rate), or
            feature rows at the ``fps`` given at construction.

        Returns
        -------
        self
        """
        from streamseg.offline.missing_frames import bridge_rows

        cfg = self.config
        self.lost_joints_ = []
        if hasattr(X, "positions") and hasattr(X, "skeleton"):
            fps = float(X.fps)
            # lost joints are bridged in the counter, frame by frame as live
            self.lost_joints_, self.n_missing_frames_, unusable = _lost(X)
            P = X.positions
            n = P.shape[0]
            counter = RepetitionCounter(cfg, fps, X.skeleton)
            data = None if (n and unusable) else P
            self.features_ = np.zeros((n, 28)) if data is None or n == 0 else stream_features(X)
        else:
            fps = self.fps
            A = np.asarray(X, dtype=np.float64)
            if A.ndim != 2:
                raise ParameterError(f"X must be (n_frames, d) feature rows; got shape {A.shape}")
            bad = bad_frames(A)
            self.n_missing_frames_ = int(bad.sum())
            n = A.shape[0]
            data = (
                None
                if (self.n_missing_frames_ == n and n)
                else (bridge_rows(A, bad) if self.n_missing_frames_ else A)
            )
            counter = RepetitionCounter(cfg, fps, None)
            self.features_ = np.zeros_like(A) if data is None else data
        if data is not None and n:
            counter.learn_many(data)
            counter.finish()
        self.counter_ = counter
        self.fps_ = fps
        self.n_frames_ = n
        self.sets_ = [set_summary(s, fps, cfg) for s in counter.sets_]
        self.repetitions_ = [r for s in self.sets_ for r in s["repetitions"]]
        self.count_ = len(self.repetitions_)
        self.repetitive_ = bool(self.sets_)
        self.reason_ = "" if self.repetitive_ else self._reason(counter, n, data is None)
        self.segments_ = [Segment(int(a), int(b), i) for i, (a, b) in enumerate(self.repetitions_)]
        self.labels_ = np.full(n, -1, dtype=np.int64)
        self.set_labels_ = np.full(n, -1, dtype=np.int64)
        for i, (a, b) in enumerate(self.repetitions_):
            self.labels_[a:b] = i
        for i, s in enumerate(self.sets_):
            self.set_labels_[s["start"] : s["end"]] = i
        return self

    def _reason(self, counter, n, unusable) -> str:
        cfg = self.config
        if unusable:
            return (
                f"every frame ({n}) has missing (NaN) trunk or hip joints: no pose to "
                "read the limbs' movement in"
            )
        if n < 2 * counter._ring.dec + 2:
            return f"too short: {n} frame{'' if n == 1 else 's'}"
        if counter.max_excursion_ < cfg.min_amplitude:
            return (
                f"no movement as large as a repetition (the pose went at most "
                f"{counter.max_excursion_:.2f} from where it was; min_amplitude "
                f"{cfg.min_amplitude:g})"
            )
        if counter.n_loops_ == 0:
            return "the pose never came back to where it was: no cycle"
        if not np.isfinite(counter.best_dissimilarity_):
            return "one cycle only: a repetition needs a second one like it"
        misses = counter.near_misses_
        if counter.best_dissimilarity_ <= cfg.max_dissimilarity and misses:
            why = {
                "tempo": f"their durations differ more than start_tempo_ratio "
                f"{cfg.start_tempo_ratio:g} times",
                "span": f"together they cover a pose range wider than the larger one "
                f"(spread_ratio {cfg.spread_ratio:g}): parts of a longer movement",
                "amplitude": f"one moved less than amplitude_ratio "
                f"{cfg.amplitude_ratio:g} of the other",
            }
            fault = max(misses, key=misses.get)
            n = sum(misses.values())
            return (
                f"consecutive cycles alike in shape ({n} pair{'s' if n > 1 else ''}, the "
                f"closest {counter.best_dissimilarity_:.2f} of their amplitude) but not "
                f"repetitions of one movement: {why[fault]}"
            )
        return (
            f"no two consecutive cycles alike (the closest differ by "
            f"{counter.best_dissimilarity_:.2f} of their amplitude; max_dissimilarity "
            f"{cfg.max_dissimilarity:g})"
        )

    def predict(self) -> list[Segment]:
        """The repetitions, ``Segment(start, end, index)`` (0-based, end exclusive)."""
        self._check_fitted()
        return list(self.segments_)
