"""Offline repetition segmentation (Wang et al. 2015): UKF angles -> frequency -> boundaries.

The section-4 analysis and the "repetitive" test are in :mod:`streamseg.offline.rep_analysis`
(shared with the live counter); the DTW re-cut in :mod:`streamseg.offline.rep_align`.
"""

from __future__ import annotations

import numpy as np

from streamseg.config import RepetitionConfig
from streamseg.exceptions import ParameterError
from streamseg.kinematics.model import (
    ANGLE_NAMES,
    BONE_NAMES,
    bone_directions,
    estimate_noise,
    fit_angles,
    limb_points,
    observations,
)
from streamseg.offline import repetition_steps as steps
from streamseg.offline.missing_frames import bad_frames, bridge_missing_frames, bridge_rows
from streamseg.offline.rep_align import align_repetitions
from streamseg.offline.rep_analysis import (
    analyse,
    not_repetitive_reason,
    rest_pose,
    smooth,
)
from streamseg.offline.root_height import with_root_height
from streamseg.segments import Estimator, Segment

__all__ = ["RepetitionSegmenter", "angles_from_positions"]


def angles_from_positions(positions, names, fps, config: RepetitionConfig | None = None):
    """The 20 model joint angles per frame by the four-pass UKF (section 3).

    Parameters
    ----------
    positions : ndarray, shape (n_frames, n_joints, 3)
    names : sequence of str
        Joint names (Acclaim bone names, positions at bone ends).
    fps : float
    config : RepetitionConfig, optional

    Returns
    -------
    ndarray, shape (n_frames, 20)
        In :data:`streamseg.kinematics.model.ANGLE_NAMES` order, radians.
    """
    cfg = config or RepetitionConfig()
    pts = limb_points(np.asarray(positions, dtype=np.float64), names)
    Y, scale, pdir, l0 = observations(pts, fps, cfg.torso_cutoff_hz)
    noise = cfg.position_noise
    if cfg.estimate_noise:  # noisier sensors (Kinect) get a proportionally larger R
        noise = max(noise, estimate_noise(np.asarray(positions), scale))
    angles, _ = fit_angles(Y, fps, pdir, l0, position_noise=noise,
                           angle_speed=cfg.angle_speed, length_speed=cfg.length_speed,
                           passes=cfg.ukf_passes)
    return angles


def _snap(reps, curve, fraction, level=0.0, position=0.5):
    """Move each inner cut of consecutive ``reps`` into the pause of ``curve`` nearby.

    The window is ``fraction`` of the shorter neighbouring piece either side of the cut (so
    cuts keep their order). With ``level`` 0 the cut goes to the window's minimum of
    ``curve``; otherwise to ``position`` (0 = its first frame, 1 = its last) of the pause:
    the frames around that minimum, inside the window, whose ``curve`` stays within
    ``level`` x the window's range above the minimum.
    """
    cuts = [a for a, _ in reps] + [reps[-1][1]]
    out = list(cuts)
    for i in range(1, len(cuts) - 1):
        r = int(fraction * min(cuts[i] - cuts[i - 1], cuts[i + 1] - cuts[i]))
        if r > 0:
            a, z = max(out[i - 1] + 1, cuts[i] - r), cuts[i] + r + 1
            w = curve[a:z]
            m = int(np.argmin(w))
            if level > 0:
                low = w <= w[m] + level * (w.max() - w[m])
                lo, hi = m, m
                while lo > 0 and low[lo - 1]:
                    lo -= 1
                while hi < w.size - 1 and low[hi + 1]:
                    hi += 1
                m = int(round(lo + position * (hi - lo)))
            out[i] = a + m
    return list(zip(out[:-1], out[1:]))


def _too_short(n: int) -> str:
    return f"too short: {n} frame{'' if n == 1 else 's'}"


class RepetitionSegmenter(Estimator):
    """Cut a repetitive exercise into repetitions (offline).

    Parameters
    ----------
    config : RepetitionConfig, optional
    fps : float
        Frame rate of an array given to :meth:`fit` (a Recording brings its own).

    Attributes
    ----------
    repetitions_ : list of (int, int)
        0-based (start, end), end exclusive.
    segments_ : list of Segment
        The repetitions as ``Segment(start, end, index)`` (what :meth:`predict` returns; they
        need not tile the take: frames outside every repetition are in none).
    labels_ : ndarray of int64, shape (n_frames,)
        Repetition index per frame, -1 outside every repetition.
    count_ : int
        0 when the sequence is not repetitive.
    repetitive_ : bool
        Whether the sequence passed the "repetitive" test (:func:`not_repetitive_reason`,
        the repetitions found included: at least :func:`min_repetitions`); a single
        repetition, two, a still or a non-repetitive take do not.
    reason_ : str
        Why not ("" when repetitive).
    primary_frequency_hz_ : float
        0 when there was nothing to analyse.
    angles_ : ndarray, shape (n_frames, n_params)
        The parameters analysed: for a recording, the unit directions of the model's 10
        bones computed from the UKF joint angles (n_params = 30), and with
        ``root_height_weight > 0`` the weighted root height (:func:`with_root_height`,
        n_params = 31); for an array, the array.
    joint_angles_ : ndarray, shape (n_frames, 20)
        The UKF joint angles (recordings only).
    param_names_ : tuple of str
    analysis_ : RepetitionAnalysis or None
        None for a still or too short sequence.
    n_missing_frames_ : int
        Frames (rows) with a NaN or infinite value, skipped: bridged by interpolation from
        the good frames around them (:mod:`streamseg.offline.missing_frames`).
    n_frames_ : int
    fps_ : float
    """

    def __init__(self, config: RepetitionConfig | None = None, fps: float = 120.0):
        self.config = config or RepetitionConfig()
        if not (np.isscalar(fps) and float(fps) > 0):
            raise ParameterError(f"fps={fps!r} is invalid: expected the frame rate (> 0) of "
                                 "the arrays given to fit")
        self.fps = float(fps)

    def fit(self, X) -> RepetitionSegmenter:
        """Segment a recording or parameter trajectories.

        Parameters
        ----------
        X : Recording or ndarray, shape (n_frames, n_params)
            A recording (joint positions, Acclaim joint names; its own frame rate) or angle
            trajectories (at the ``fps`` given at construction).

        Returns
        -------
        self
        """
        fps = self.fps
        unusable = ""  # why there is nothing to analyse before any motion test
        if hasattr(X, "positions") and hasattr(X, "skeleton"):
            fps = float(X.fps)
            X, self.n_missing_frames_ = bridge_missing_frames(X)
            n = X.positions.shape[0]
            if n < 4 or self.n_missing_frames_ == n:
                # nothing the UKF can start from: no angles, no motion
                unusable = (_too_short(n) if n < 4 else
                            f"every frame ({n}) has missing (NaN) joint positions")
                self.joint_angles_ = np.zeros((n, len(ANGLE_NAMES)))
                self.angles_ = np.zeros((n, len(BONE_NAMES)))
            else:
                angles = angles_from_positions(X.positions, X.skeleton.names, fps, self.config)
                # Analysed: the bones' unit directions from the UKF angles. The 3-DoF
                # shoulder's Euler angles jump between equivalent branches when an arm circles
                # through 360 degrees (and wind by 2 pi per circle); the directions do neither.
                self.joint_angles_ = angles
                self.angles_ = with_root_height(bone_directions(angles), X, self.config)
            self.param_names_ = BONE_NAMES + (("root_height",) if self.angles_.shape[1]
                                              > len(BONE_NAMES) else ())
        else:
            if fps is None or not fps > 0:
                raise ParameterError(f"fps={fps!r} is invalid: expected the frame rate (> 0) "
                                     "when fitting on an array")
            A = np.asarray(X, dtype=np.float64)
            if A.ndim != 2:
                raise ParameterError(f"X must be (n_frames, n_params) trajectories; got "
                                     f"shape {A.shape}")
            bad = bad_frames(A)
            self.n_missing_frames_ = int(bad.sum())
            if self.n_missing_frames_ == A.shape[0] and A.shape[0]:
                unusable = f"every row ({A.shape[0]}) has a NaN"
                A = np.zeros_like(A)
            elif self.n_missing_frames_:
                A = bridge_rows(A, bad)  # skipped rows bridged, as a recording's frames
            self.angles_ = A
            self.param_names_ = tuple(f"p{i}" for i in range(A.shape[1]))
        self.fps_ = float(fps)
        self.n_frames_ = self.angles_.shape[0]
        cfg = self.config
        self.analysis_ = None
        self.primary_frequency_hz_ = 0.0
        self.repetitions_ = []
        if (unusable or self.n_frames_ < 4
                or float(self.angles_.std(axis=0).max()) < cfg.still_std):
            self.reason_ = unusable or ("no motion" if self.n_frames_ >= 4
                                        else _too_short(self.n_frames_))
        else:
            try:
                a = analyse(self.angles_, self.fps_, cfg)
            except ParameterError:  # no admissible frequency: shorter than min_cycles cycles
                a = None
            self.analysis_ = a
            self.reason_ = not_repetitive_reason(a, cfg)
            if a is not None:
                self.primary_frequency_hz_ = a.primary_hz
            if not self.reason_:
                self.repetitions_ = steps.to_repetitions(a.boundaries, self.n_frames_,
                                                         a.period, cfg.edge_fraction, a.speed2,
                                                         merge_edges=cfg.merge_edges)
                if cfg.align == "dtw" and len(self.repetitions_) >= 2:
                    self.repetitions_ = self._align(a)
                # the cycles rule on the pieces found too (whole take and set alike)
                self.reason_ = not_repetitive_reason(a, cfg, len(self.repetitions_))
                if self.reason_:
                    self.repetitions_ = []
        self.repetitive_ = not self.reason_
        self.count_ = len(self.repetitions_)
        reps = self.repetitions_
        self.segments_ = [Segment(int(a), int(b), i) for i, (a, b) in enumerate(reps)]
        labels = np.full(self.n_frames_, -1, dtype=np.int64)
        for i, (a, b) in enumerate(reps):
            labels[a:b] = i
        self.labels_ = labels
        return self

    def _align(self, a):
        """The repetitions re-cut by DTW against a template (``align="dtw"``)."""
        cfg = self.config
        F, cols = self.alignment_features(a)
        reps = align_repetitions(F, self.repetitions_, self.fps_, rate_hz=cfg.align_rate_hz,
                                 stretch=cfg.align_stretch, iterations=cfg.align_iterations,
                                 max_slope=cfg.align_max_slope,
                                 max_compress=cfg.align_max_compress)
        if cfg.align_snap > 0:
            # a template starts and ends at the rest pose, so a cut may sit anywhere in a
            # pause: it goes to the frame nearest that pose, as the spectral boundaries do,
            # or to a set place in the pause (align_snap_level > 0)
            rest = rest_pose(self.angles_[:, cols], a.period)
            reps = _snap(reps, np.sum((F - rest) ** 2, axis=1), cfg.align_snap,
                         cfg.align_snap_level, cfg.align_snap_position)
        return reps

    def alignment_features(self, a):
        """What the DTW re-cut compares: the aligned columns, low-passed.

        ``align_features`` "selected": the selected parameters; "all": every analysed one.
        With ``root_height_weight > 0`` the last analysed column (the root height,
        :func:`with_root_height`; an array is taken to carry it there) is always among them:
        the selection may drop it where the bones carry most of the power, and the template
        is what must tell a bounce from a hop.

        Returns
        -------
        F : ndarray, shape (n_frames, n_cols)
        cols : ndarray of int, shape (n_cols,)
        """
        cfg = self.config
        n = self.angles_.shape[1]
        cols = a.selected if cfg.align_features == "selected" else np.arange(n)
        if cfg.root_height_weight > 0 and n - 1 not in cols:
            cols = np.append(cols, n - 1)
        F = smooth(self.angles_[:, cols], self.fps_, cfg.refine_band * a.primary_hz,
                   cfg.filter_order)
        return F, cols

    def predict(self) -> list[Segment]:
        """The repetitions, ``Segment(start, end, index)`` (0-based, end exclusive)."""
        self._check_fitted()
        return list(self.segments_)
