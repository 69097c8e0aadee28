"""Streaming and offline LOF cut detection."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

from streamseg.config._base import _check
from streamseg.exceptions import ParameterError


@dataclass(frozen=True)
class LOFConfig:
    """Sliding-window histogram + Local Outlier Factor cut detection.

    Times are in seconds and converted to frames with the stream's rate, so one configuration
    serves 30, 100 and 120 Hz streams. The defaults were chosen on two recordings only (CMU 86_01
    and 14_14, see ``benchmarks/lof_accuracy.py``) and are held fixed for every other one;
    :meth:`paper` gives the settings of Xing et al. (2015). Why they differ from the paper's:
    a 2.25 s window holds one or two cycles of a cyclic action yet is shorter than the
    shortest action in those recordings (3.8 s), so an action spans 15-50 windows at a 0.2 s
    step; ``k = 10 ~ window / step`` makes a transition window's neighbourhood about as long
    as the run of windows that straddle the transition, so it reaches into the clusters on
    either side; the threshold adapts to the curve (median + 1 MAD-sigma, floor 1.3). The
    delay is the price of causality: a transition window becomes a density outlier only once
    about k windows of the next action exist (k * step = 2 s); streaming F1 on the two
    recordings was 0.22, 0.58, 0.90 with delays of 1, 2, 2.5 s (2 s windows, 10 bins).

    Selection (streaming F1 on 86_01 + 14_14, label window + 0.5 s): the train scores of
    neighbouring settings differ by one or two of the 11 true cuts, so each value is the one
    whose score averaged with its grid neighbours is highest, not an isolated best. Over bins
    5-10 x window 2-3 s x k 8-12 that is 6 bins, 2.25 s, k 10 (train F1 0.92, neighbourhood
    0.85; 10 bins, 2 s, k 10 had 0.85 and 0.78); then over delay 2-3 s x floor 1.2-1.5 x
    threshold 1-2 MADs: 2.5 s, 1.3, 1.0 (train F1 0.96). Six bins of 30 degrees are coarse
    enough that a window's histogram barely moves within one action.

    Attributes
    ----------
    window_s : float
        Sliding-window length in seconds (paper: 500 frames at 120 Hz).
    step_s : float
        Distance between consecutive window starts in seconds (paper: 45 frames).
    bins : int
        Equal-width histogram bins per bone angle over [0, pi] (paper: L = 10).
    k : int
        LOF neighbourhood size (paper: 20).
    buffer_s : float
        Seconds of window vectors the streaming detector keeps for LOF (bounds memory).
    delay_s : float
        A window is decided this long after it is complete: the peak rule looks this far to
        either side of it, so it is also the confirmation delay of the streaming detector.
    threshold_mads : float
        Adaptive threshold: a peak must reach ``median + threshold_mads * 1.4826 * MAD`` of the
        LOF values in the buffer (the curve's own level, not a fixed LOF value).
    min_score : float
        A peak's LOF must also reach this floor (LOF ~ 1 inside a cluster).
    dp_tolerance : float
        Douglas-Peucker tolerance as a fraction of the local curve's range (max - min).
    min_gap_s : float
        Two cuts are at least this far apart; the first confirmed one wins.
    min_valid : float
        Fraction of non-NaN frames a window needs to be used (NaN frames are skipped).
    exclusion : float
        Temporal exclusion zone, in window lengths: windows whose centres are closer than
        ``exclusion * window`` are not each other's LOF neighbours. Overlapping windows are
        trivially similar, so without it (0, the paper and scikit-learn) the neighbourhoods
        follow the time axis instead of the action clusters.
    refine_s : float
        Cut localisation: the cut moves from the peak window's centre (the paper's rule,
        ``refine_s = 0``) to the frame within ``refine_s`` seconds of it where the histograms
        of the ``window_s`` before and the ``window_s`` after differ most (cosine distance),
        using only frames seen when the cut is decided, and ``min_gap_s`` after the previous
        cut. Chosen on 86_01 and 14_14 (``benchmarks/lof_variants.py``): streaming F1 0.88
        with the centre rule, 0.96 with 0.4 s; radii of 0.2, 0.8 and 1 s gave 0.88. Shorter
        sub-windows (1 or 1.5 s at 0.4 s) scored the same F1 with localisation errors within
        3 frames of it, 0.5 s scored worse, so the sub-window is the LOF window (no extra
        parameter).
    inclinations : bool
        Features: the paper's 8 bone angles (False) or those plus each of its 9 bones' angle
        from the up axis (True, :data:`streamseg.skeleton.bones.INCLINATIONS`; the
        skeleton's ``up``). Angles between bones cannot tell a pose from the same pose
        tilted, e.g. standing from bending over. Chosen on 86_01 and 14_14 with every other
        default held (``benchmarks/lof_variants.py``, part 4): streaming F1 0.96 with the 8
        angles, 1.00 with all 9 inclinations; subsets (spine only, spine and proximal limbs)
        scored lower and the 8 limb bones tied, so the complete set was kept.
    """

    window_s: float = 2.25
    step_s: float = 0.2
    bins: int = 6
    k: int = 10
    buffer_s: float = 75.0
    delay_s: float = 2.5
    threshold_mads: float = 1.0
    min_score: float = 1.3
    dp_tolerance: float = 0.1
    min_gap_s: float = 1.0
    min_valid: float = 0.5
    exclusion: float = 0.0
    refine_s: float = 0.4
    inclinations: bool = True

    def __post_init__(self):
        _check("window_s", self.window_s, self.window_s > 0, "a window length > 0 seconds")
        _check(
            "step_s",
            self.step_s,
            0 < self.step_s <= self.window_s,
            "a step > 0 and <= window_s seconds",
        )
        _check(
            "bins",
            self.bins,
            isinstance(self.bins, int) and 2 <= self.bins <= 64,
            "an integer number of bins in [2, 64]",
        )
        _check("k", self.k, isinstance(self.k, int) and self.k >= 1, "an integer k >= 1")
        _check(
            "buffer_s",
            self.buffer_s,
            self.buffer_s >= self.window_s,
            "a buffer of at least window_s seconds",
        )
        _check("delay_s", self.delay_s, self.delay_s > 0, "a delay > 0 seconds")
        _check(
            "threshold_mads", self.threshold_mads, self.threshold_mads >= 0, "a number of MADs >= 0"
        )
        _check("min_score", self.min_score, self.min_score >= 0, "a LOF floor >= 0")
        _check(
            "dp_tolerance", self.dp_tolerance, 0 <= self.dp_tolerance < 1, "a fraction in [0, 1)"
        )
        _check("min_gap_s", self.min_gap_s, self.min_gap_s >= 0, "a gap >= 0 seconds")
        _check("min_valid", self.min_valid, 0 < self.min_valid <= 1, "a fraction in (0, 1]")
        _check("exclusion", self.exclusion, self.exclusion >= 0, "a number of windows >= 0")
        _check("refine_s", self.refine_s, self.refine_s >= 0, "a search radius >= 0 seconds")
        _check("inclinations", self.inclinations, isinstance(self.inclinations, bool),
               "true or false")

    @property
    def n_features(self) -> int:
        """Columns of a feature frame: 8 bone angles, plus 9 inclinations when enabled."""
        return 17 if self.inclinations else 8

    @classmethod
    def paper(cls, **overrides) -> LOFConfig:
        """Xing et al. (2015): 500-frame windows, step 45 at 120 Hz, L = 10 bins, k = 20.

        The paper states no peak threshold; the adaptive rule is kept with its defaults. The
        cut is the peak window's centre (``refine_s = 0``) and the features are the 8 bone
        angles (no inclinations), as in the paper.
        """
        values = dict(window_s=500 / 120, step_s=45 / 120, bins=10, k=20, exclusion=0.0,
                      refine_s=0.0, inclinations=False)
        values.update(overrides)
        return cls(**values)

    def frames(self, fps: float) -> dict:
        """Integer frame/window counts for a stream at ``fps``.

        Returns
        -------
        dict
            ``window``, ``step`` (frames), ``capacity``, ``delay``, ``min_gap`` (windows),
            ``min_valid``, ``exclusion``, ``refine`` (frames) and ``history`` (frames the
            streaming detector keeps: the last window plus what cut localisation may look at).
        """

        _check("fps", fps, fps > 0, "a frame rate > 0")
        window = max(2, int(round(self.window_s * fps)))
        step = max(1, min(window, int(round(self.step_s * fps))))
        delay = max(1, int(round(self.delay_s * fps / step)))
        # the peak rule needs delay windows on both sides of the window it decides
        capacity = max(self.k + 2, 2 * delay + 1, int(round(self.buffer_s * fps / step)))
        refine = int(round(self.refine_s * fps))
        # a cut is decided delay * step + window - 1 - window // 2 frames after its window's
        # centre; localisation looks refine + window frames before that centre
        history = window if refine == 0 else delay * step + 2 * window + refine + 1
        return dict(
            window=window,
            step=step,
            capacity=capacity,
            delay=delay,
            min_gap=int(round(self.min_gap_s * fps / step)),
            exclusion=int(round(self.exclusion * window)),
            min_valid=max(1, math.ceil(self.min_valid * window - 1e-9)),
            refine=refine,
            history=history,
        )


def feature_width(config: LOFConfig, n_features) -> int:
    """Columns per frame a segmenter takes: ``n_features`` (validated) or ``config.n_features``."""
    if n_features is None:
        return config.n_features
    if isinstance(n_features, bool) or not isinstance(n_features, numbers.Integral) \
            or n_features < 1:
        raise ParameterError(f"n_features={n_features!r} is invalid: expected an int >= 1")
    return int(n_features)


def width_message(shape, d: int, config: LOFConfig, n_features, row: bool = False) -> str:
    """The error for features of the wrong width (``row``: one frame), with the fix when the
    config chose the width."""
    name, want = ("angles_row", f"({d},)") if row else ("angles", f"(n_frames, {d})")
    msg = f"{name} has shape {shape}; expected {want}"
    if n_features is not None:
        return msg
    msg += (f": the config's features, streamseg.skeleton.bone_angles(..., "
            f"inclinations={config.inclinations})")
    other = not config.inclinations
    if len(shape) in (1, 2) and shape[-1] == LOFConfig(inclinations=other).n_features:
        msg += f"; {shape[-1]} columns are for LOFConfig(inclinations={other})"
    return msg
