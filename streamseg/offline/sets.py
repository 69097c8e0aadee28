"""A whole routine counted per exercise: actions from HACA, repetitions inside each set.

A session is a routine (jumping jacks, then squats, then arm circles), not one exercise. The
take is first cut into actions the way ``segment --method aca`` does (HACA on the 14-joint
quaternion features, the number of actions found by :func:`fit_aca`); adjacent segments of
one label are one *set*; the repetition segmenter then runs inside each set on the bone
directions of the kinematic UKF fitted once on the whole take. A recording without joint
rotations is cut on :func:`streamseg.skeleton.body_features` instead of the quaternions. A
set that fails the "repetitive" test (:func:`streamseg.offline.rep_analysis.
not_repetitive_reason`) has count 0.

A take that is one repetitive exercise as a whole (it passes the repetitive test with a power
concentration of at least ``repetitive_ratio``, the live counter's stricter threshold) is
one set: HACA always finds at least two actions and would otherwise cut one exercise in two.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from streamseg.config import ACAConfig, RepetitionConfig
from streamseg.offline.repetition import RepetitionSegmenter
from streamseg.segments import Estimator, Segment

__all__ = ["RepetitionSet", "RoutineSegmenter"]


@dataclass(frozen=True)
class RepetitionSet:
    """One action segment of a routine and its repetitions.

    Attributes
    ----------
    start, end : int
        Frames, 0-based, end exclusive.
    label : int
        Action label (sets of one label are the same action).
    count : int
    repetitive : bool
    reason : str
        Why the set is not repetitive ("" when it is).
    repetitions : list of (int, int)
        In frames of the whole take.
    """

    start: int
    end: int
    label: int
    count: int
    repetitive: bool
    reason: str = ""
    repetitions: list = field(default_factory=list)


def merge_runs(segments) -> list:
    """Adjacent ``(start, end, label)`` segments of one label joined."""
    out = []
    for s, e, lab in segments:
        if out and out[-1][2] == lab and out[-1][1] == s:
            out[-1] = (out[-1][0], e, lab)
        else:
            out.append((int(s), int(e), int(lab)))
    return out


class RoutineSegmenter(Estimator):
    """Cut a take into action sets and count the repetitions of each.

    Parameters
    ----------
    config : RepetitionConfig, optional
    fps : float
        Kept for the common convention; a Recording brings its own frame rate.
    aca_config : ACAConfig, optional
        Default: the ``segment --method aca`` defaults for recordings (HACA, K found).

    Attributes
    ----------
    sets_ : list of RepetitionSet
    segments_ : list of Segment
        The sets as ``Segment(start, end, action label)`` (what :meth:`predict` returns).
    whole_ : RepetitionSegmenter
        The repetition segmenter fitted on the whole take.
    count_ : int
        Repetitions over every set.
    repetitions_ : list of (int, int)
        Every set's repetitions, in order.
    n_clusters_ : int
        Actions HACA found (1 when the take was one exercise, or had nothing to analyse).
    n_missing_frames_ : int
        Frames with NaN joint positions, skipped (bridged: :mod:`streamseg.offline.
        missing_frames`).
    """

    def __init__(self, config: RepetitionConfig | None = None, fps: float = 120.0,
                 aca_config: ACAConfig | None = None):
        self.config = config or RepetitionConfig()
        self.fps = float(fps)
        self.aca_config = aca_config or ACAConfig()

    def fit(self, recording) -> RoutineSegmenter:
        """Segment a recording (joint positions, Acclaim joint names).

        Returns
        -------
        self
        """
        from streamseg.offline.missing_frames import bridge_missing_frames
        from streamseg.offline.model_selection import fit_aca
        from streamseg.skeleton import body_features, quaternion_features

        cfg = self.config
        # frames with NaN joints bridged once, for the action features and the UKF alike
        recording, self.n_missing_frames_ = bridge_missing_frames(recording)
        whole = RepetitionSegmenter(cfg, self.fps).fit(recording)
        whole.n_missing_frames_ = self.n_missing_frames_
        self.whole_ = whole
        fps = whole.fps_
        a = whole.analysis_
        if a is None or (whole.repetitive_ and a.concentration >= cfg.repetitive_ratio):
            # nothing to analyse (too short, still, no good frame): no part of it is a set
            # either; or one exercise as a whole
            runs = [(0, whole.n_frames_, 0)] if whole.n_frames_ else []
            self.n_clusters_ = 1 if whole.n_frames_ else 0
        else:
            if getattr(recording, "rotations", None) is not None:
                X = quaternion_features(recording)
            else:  # positions only (a live stream, an array): the body's bone directions
                X = body_features(recording.positions, recording.skeleton)
            model = fit_aca(X, self.aca_config, fps)
            runs = merge_runs(model.segments_)
            self.n_clusters_ = int(model.n_clusters_)
        sets = []
        for s, e, lab in runs:
            if len(runs) == 1:
                seg = whole
            else:
                seg = RepetitionSegmenter(cfg, fps).fit(whole.angles_[s:e])
            reps = [(int(a_ + s), int(b + s)) for a_, b in seg.repetitions_]
            sets.append(RepetitionSet(int(s), int(e), int(lab), len(reps), bool(seg.repetitive_),
                                      seg.reason_, reps))
        self.sets_ = sets
        self.segments_ = [Segment(st.start, st.end, st.label) for st in sets]
        self.repetitions_ = [r for st in sets for r in st.repetitions]
        self.count_ = len(self.repetitions_)
        self.n_frames_ = whole.n_frames_
        self.fps_ = fps
        return self

    def set_labels(self) -> np.ndarray:
        """Set index per frame, shape (n_frames,)."""
        out = np.full(self.n_frames_, -1, dtype=np.int64)
        for i, st in enumerate(self.sets_):
            out[st.start:st.end] = i
        return out
