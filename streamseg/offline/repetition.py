"""Offline repetition segmentation (Wang et al. 2015): UKF angles -> frequency -> boundaries."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import detrend, hilbert

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
from streamseg.offline.root_height import with_root_height
from streamseg.segments import Estimator, Segment

__all__ = ["RepetitionAnalysis", "RepetitionSegmenter", "angles_from_positions", "analyse",
           "min_repetitions", "not_repetitive_reason"]


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


@dataclass(frozen=True)
class RepetitionAnalysis:
    """Everything section 4 computes on one sequence (for plots and the live counter).

    Attributes
    ----------
    primary_cycles : float
        Primary frequency in cycles per sequence.
    primary_hz : float
    period : float
        Frames per cycle.
    selected : ndarray of int, shape (M,)
        Selected parameter columns.
    filtered : ndarray, shape (n_frames, M)
        Band-passed selected parameters.
    speed2 : ndarray, shape (n_frames,)
        Sum of squared velocities of ``filtered`` (eq. 10's curve).
    candidates : ndarray of int, shape (N,)
    labels : ndarray of int, shape (N,)
        Group of each candidate: adaptive k-means clusters, same-phase clusters merged.
    k_star : int
    group : int
        The chosen group (eq. 14), or -1 when there were no candidates.
    boundaries : ndarray of int
        Candidates of the chosen group.
    concentration : float
        Share of the summed spectral power (above ``min_cycles``) inside the band.
    subharmonic : float
        Summed power at half the primary frequency over that at the primary frequency (large
        when the "primary" is really a harmonic of a longer period).
    """

    primary_cycles: float
    primary_hz: float
    period: float
    selected: np.ndarray
    filtered: np.ndarray
    speed2: np.ndarray
    candidates: np.ndarray
    labels: np.ndarray
    k_star: int
    group: int
    boundaries: np.ndarray
    concentration: float
    subharmonic: float


def analyse(X, fps, config: RepetitionConfig | None = None) -> RepetitionAnalysis:
    """Section 4 on parameter trajectories.

    Parameters
    ----------
    X : ndarray, shape (n_frames, n_params)
        Kinematic parameters (e.g. UKF joint angles), radians.
    fps : float
    config : RepetitionConfig, optional

    Returns
    -------
    RepetitionAnalysis
    """
    cfg = config or RepetitionConfig()
    X = np.asarray(X, dtype=np.float64)
    n = X.shape[0]
    cycles, power = steps.power_spectrum(X, cfg.fft_pad)
    max_cycles = cfg.max_frequency_hz * n / fps
    ip = steps.primary_frequency(cycles, power, min_cycles=cfg.min_cycles, max_cycles=max_cycles)
    fc = float(cycles[ip])
    selected = steps.select_parameters(power[ip], cfg.power_ratio)
    half = 0.5 * cfg.band_width_cycles
    band = (cycles >= fc - half) & (cycles <= fc + half)
    above = cycles >= cfg.min_cycles
    total = power[above].sum()
    concentration = float(power[band & above].sum() / total) if total > 0 else 0.0
    summed = power.sum(axis=1)
    sub = float(summed[int(np.argmin(np.abs(cycles - fc / 2)))] / max(summed[ip], 1e-300))
    to_hz = fps / n
    # The filter's band is wider than the concentration band: a narrow band makes the filtered
    # parameters near-sinusoids whose velocity minima come evenly spaced, whatever the length
    # of each repetition; a wider one lets the phase follow slower and faster repetitions.
    fh = 0.5 * cfg.bandpass_width_cycles
    filtered = steps.bandpass(X[:, selected], fps, (fc - fh) * to_hz, (fc + fh) * to_hz,
                              cfg.filter_order)
    vel = np.gradient(filtered, axis=0)
    speed2 = np.sum(vel**2, axis=1)
    period = n / fc
    window = max(3, int(round(cfg.window_fraction * period)))
    cand = steps.candidate_points(speed2, window)
    # Clustered: each selected parameter's phase, cos(phase) = x' / envelope (analytic
    # signal). The paper clusters the parameter values; amplitudes drift over a set (the
    # first circles smaller than the later ones) and k-means then groups by time, not phase.
    phase = filtered / np.maximum(np.abs(hilbert(filtered, axis=0)), 1e-12)
    labels, k_star = steps.adaptive_kmeans(phase[cand], cfg.k_max, cfg.kmeans_restarts,
                                           cfg.seed)
    labels = steps.merge_same_phase(phase[cand], labels, cfg.merge_phase)
    if cand.size == 0:
        group, bounds = -1, cand
    else:
        # The rest pose: the raw parameters at the sequence's ends (see select_group).
        rest = _rest_pose(X[:, selected], period)
        raw = X[cand][:, selected]
        dist = np.full(int(labels.max()) + 1, np.inf)
        for k in np.unique(labels):
            dist[k] = float(np.linalg.norm(raw[labels == k].mean(axis=0) - rest))
        group = steps.select_group(cand, labels, n, period, dist, cfg.tie_tolerance)
        bounds = cand[labels == group]
        if cfg.refine_fraction > 0:
            # (the chosen group's own mean pose as the target instead of the ends' pose, which
            # live would need, gave bd alpha 0.904 against 0.958)
            bounds = _refine(bounds, X[:, selected], fps, fc * to_hz, period, cfg, rest)
    return RepetitionAnalysis(fc, fc * to_hz, period, selected, filtered, speed2, cand, labels,
                              k_star, group, bounds, concentration, sub)


def _refine(bounds, Xs, fps, f_hz, period, cfg, rest=None):
    """Move each boundary to the nearest velocity minimum (or rest pose) of a wider band.

    The narrow band-pass around the primary frequency makes every parameter nearly a sinusoid,
    so its velocity minima come almost evenly spaced even when repetitions differ in length.
    Each boundary is moved to the smallest squared-velocity sum of the same parameters
    low-passed at ``refine_band`` times the primary frequency, within ``refine_fraction``
    periods of where it was.
    """
    if cfg.refine_to == "rest" and rest is not None:
        # the pose nearest the rest pose
        s2 = np.sum((_smooth(Xs, fps, cfg.refine_band * f_hz, cfg.filter_order) - rest) ** 2,
                    axis=1)
    else:
        wide = steps.bandpass(Xs, fps, 0.0, cfg.refine_band * f_hz, cfg.filter_order)
        s2 = np.sum(np.gradient(wide, axis=0) ** 2, axis=1)
    r = max(1, int(round(cfg.refine_fraction * period)))
    out = []
    for b in bounds:
        a, z = max(0, int(b) - r), min(s2.shape[0], int(b) + r + 1)
        out.append(a + int(np.argmin(s2[a:z])))
    return np.array(out, dtype=np.int64)


def _rest_pose(Xs, period):
    """The mean of ``Xs`` over the first and last 5 % of a period (where a set starts/ends)."""
    ends = max(1, int(round(0.05 * period)))
    return 0.5 * (Xs[:ends].mean(axis=0) + Xs[-ends:].mean(axis=0))


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


def _smooth(Xs, fps, cutoff_hz, order):
    """``Xs`` low-passed at ``cutoff_hz`` (the filter detrends: the trend is put back)."""
    return steps.bandpass(Xs, fps, 0.0, cutoff_hz, order) + (Xs - detrend(Xs, axis=0))


def min_repetitions(config: RepetitionConfig) -> int:
    """The fewest repetitions a repeated movement is counted with: ``min_cycles + 0.5``
    cycles, rounded up (3 by default)."""
    return int(np.ceil(config.min_cycles + 0.5))


def not_repetitive_reason(a: RepetitionAnalysis | None, config: RepetitionConfig,
                          count: int | None = None) -> str:
    """Why a sequence is not a repeated movement ("" when it is one).

    A repeated movement holds at least ``min_cycles + 0.5`` cycles of its primary frequency
    (a primary at the lowest admissible bin may be one longer movement cut short), the power
    at half that frequency stays below ``max_subharmonic`` times the power at it (else the
    "primary" is a harmonic of one movement: a single squat, a single throw) and the band
    around it holds at least ``min_concentration`` of the power (noise spreads over every
    frequency). With ``count`` (the repetitions the boundaries cut), the same
    ``min_cycles + 0.5`` holds for them: at least :func:`min_repetitions`. The spectrum alone
    does not ensure it: on a short stretch (one punch and the steps around it, a set HACA cut
    out of a take) the zero-padded spectrum puts 2.5 "cycles" where the boundaries find 2
    pieces, and 2 pieces are not 2.5 cycles (``segment`` on CMU 86_01 counted such sets).
    """
    if a is None:
        return f"too short for {config.min_cycles:g} cycles"
    if a.primary_cycles < config.min_cycles + 0.5:
        return (f"fewer than {config.min_cycles + 0.5:g} cycles of the primary frequency "
                f"({a.primary_cycles:.2f}): one movement, not repetitions")
    if count is not None and count < min_repetitions(config):
        return (f"{count} repetition{'' if count == 1 else 's'} found, fewer than "
                f"{config.min_cycles + 0.5:g} cycles: not a repeated movement")
    if a.subharmonic >= config.max_subharmonic:
        return (f"the primary frequency is a harmonic of a longer movement (power at half of "
                f"it {a.subharmonic:.2f} x, limit {config.max_subharmonic:g})")
    if a.concentration < config.min_concentration:
        return (f"no dominant rhythm (power concentration {a.concentration:.2f} < "
                f"{config.min_concentration:g})")
    return ""


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
            rest = _rest_pose(self.angles_[:, cols], a.period)
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
        F = _smooth(self.angles_[:, cols], self.fps_, cfg.refine_band * a.primary_hz,
                    cfg.filter_order)
        return F, cols

    def predict(self) -> list[Segment]:
        """The repetitions, ``Segment(start, end, index)`` (0-based, end exclusive)."""
        self._check_fitted()
        return list(self.segments_)
