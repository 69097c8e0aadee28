"""Section 4 of Wang et al. (2015) on parameter trajectories, and the "repetitive" test.

:func:`analyse`: primary frequency (eq. 9), parameter selection, band-pass, candidate
boundaries (velocity minima, eq. 10), phase clustering and the chosen group (eqs. 11-14),
refined. :func:`not_repetitive_reason`: whether what it found is a repeated movement. The
offline segmenter (:mod:`streamseg.offline.repetition`) and the live counter
(:mod:`streamseg.online.repetition`) share both.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import detrend, hilbert

from streamseg.config import RepetitionConfig
from streamseg.offline import repetition_steps as steps

__all__ = ["RepetitionAnalysis", "analyse", "min_repetitions", "not_repetitive_reason",
           "rest_pose", "smooth"]


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


def analyse(X, fps, config: RepetitionConfig | None = None,
            primary_cycles: float | None = None) -> RepetitionAnalysis:
    """Section 4 on parameter trajectories.

    Parameters
    ----------
    X : ndarray, shape (n_frames, n_params)
        Kinematic parameters (e.g. UKF joint angles), radians.
    fps : float
    config : RepetitionConfig, optional
    primary_cycles : float, optional
        Take the spectrum's bin nearest this (cycles per sequence) as the primary frequency
        instead of eq. 9's strongest admissible one (for diagnoses: what another period
        would give, ``benchmarks/rep_octave.py``).

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
    if primary_cycles is not None:
        ip = int(np.argmin(np.abs(cycles - primary_cycles)))
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
        rest = rest_pose(X[:, selected], period)
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
        s2 = np.sum((smooth(Xs, fps, cfg.refine_band * f_hz, cfg.filter_order) - rest) ** 2,
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


def rest_pose(Xs, period):
    """The mean of ``Xs`` over the first and last 5 % of a period (where a set starts/ends).

    Parameters
    ----------
    Xs : ndarray, shape (n_frames, n_params)
    period : float
        Frames per repetition.

    Returns
    -------
    ndarray, shape (n_params,)
    """
    ends = max(1, int(round(0.05 * period)))
    return 0.5 * (Xs[:ends].mean(axis=0) + Xs[-ends:].mean(axis=0))


def smooth(Xs, fps, cutoff_hz, order):
    """``Xs`` low-passed at ``cutoff_hz`` (the filter detrends: the trend is put back).

    Parameters
    ----------
    Xs : ndarray, shape (n_frames, n_params)
    fps : float
    cutoff_hz : float
    order : int
        Butterworth order.

    Returns
    -------
    ndarray, shape (n_frames, n_params)
    """
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
