"""Streaming and offline LOF cut detection."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

from streamseg.config._base import _check
from streamseg.exceptions import ParameterError

#: the peak rules of :attr:`LOFConfig.peak_rule`
PEAK_RULES = ("adaptive", "paper")
#: the paper preset's Douglas-Peucker tolerance (ours: the paper gives none), see LOFConfig.paper
PAPER_TOLERANCE = 0.02


@dataclass(frozen=True)
class LOFConfig:
    """Sliding-window histogram + Local Outlier Factor cut detection (Xing et al. 2015).

    Times are in seconds, converted to frames with the stream's rate. Window ``w`` is decided
    ``delay_s`` after it is complete: it is a cut when its LOF is a peak of the buffered curve
    above the stream's own level and two-sample checks confirm that the motion differs on the
    two sides. Offline segmentation makes the same causal decisions. :meth:`paper` gives the
    published settings. Why each default: ``docs/decisions.md`` (Cuts).

    Attributes
    ----------
    window_s : float
        Sliding-window length, seconds (paper: 500 frames at 120 Hz).
    step_s : float
        Distance between consecutive window starts, seconds (paper: 45 frames).
    bins : int
        Equal-width histogram bins per feature over [0, pi] (paper: 10).
    k : int
        LOF neighbourhood size (paper: 20).
    buffer_s : float
        Seconds of windows the streaming detector keeps for LOF (bounds memory).
    delay_s : float
        A window is decided this long after it is complete (the peak rule's look-ahead).
    threshold_mads : float
        A peak must reach the buffered LOF's median + this many MAD-sigmas.
    min_score : float
        A peak's LOF must also reach this floor (LOF ~ 1 inside a cluster).
    dp_tolerance : float
        Douglas-Peucker tolerance as a fraction of the local curve's range.
    min_gap_s : float
        Two cuts are at least this far apart, seconds; the first confirmed one wins.
    min_valid : float
        Fraction of non-NaN frames a window needs to be used.
    exclusion : float
        Windows whose centres are closer than this many window lengths are not LOF neighbours.
    refine_s : float
        Seconds around the peak window's centre searched for the largest contrast (0: centre).
    inclinations : bool
        Features: the 8 bone angles (False) or those and the 9 bones' inclinations (True).
    min_contrast : float
        Confirmation: cosine distance the histograms before and after a cut must reach (0: off).
    contrast_s : float
        Length of each side of the confirming contrast, seconds.
    speed_max : float
        Angular speed, rad/s, mapped to the last bin of the speed columns (0: no speed columns).
    speed_lag_s : float
        Lag of the speed columns, seconds.
    novelty : float
        Cosine distance the current segment and the ``contrast_s`` after must reach (0: off).
    peak_rule : {"adaptive", "paper"}
        "adaptive": the threshold above; "paper": every peak vertex of the simplified curve.
    early_delay_s : float or None
        Also decide each window this early, emitted pending, settled at ``delay_s`` (None: off).
    onset_mads : float or None
        The onset rule (None: off; unused when ``early_delay_s`` is set, whose early stage
        is the peak rule at that delay instead): a pending cut as soon as the
        newest window's LOF has risen ``onset_rises`` windows in a row past the buffered
        curve's median + ``onset_mads`` scaled MADs, before its peak is known; settled at
        ``delay_s`` like the early stage's.
    onset_rises : int
        Consecutive rises of the newest window's LOF the onset rule needs.
    onset_lead_s : float
        Seconds after the newest window's centre where the onset rule places its cut (where
        the peak window's centre is expected).
    onset_gap_s : float
        Seconds from one onset to the next.
    root_speed_max : float
        Root speed, body scales/s, mapped to the last bin of the 2 root-speed columns (0: none).
    root_jump : float
        A root step faster than this, body scales/s, counts as no motion (a jump of the data).
    """

    window_s: float = 1.75
    step_s: float = 0.2
    bins: int = 6
    k: int = 5
    buffer_s: float = 75.0
    delay_s: float = 1.5
    threshold_mads: float = 1.0
    min_score: float = 1.0
    dp_tolerance: float = 0.1
    min_gap_s: float = 1.0
    min_valid: float = 0.5
    exclusion: float = 0.0
    refine_s: float = 0.8
    inclinations: bool = True
    min_contrast: float = 0.15
    contrast_s: float = 2.0
    speed_max: float = 2.0
    speed_lag_s: float = 0.1
    novelty: float = 0.15
    peak_rule: str = "adaptive"
    early_delay_s: float | None = None
    onset_mads: float | None = None
    onset_rises: int = 3
    onset_lead_s: float = 0.4
    onset_gap_s: float = 1.0
    root_speed_max: float = 3.0
    root_jump: float = 20.0

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
        _check(
            "min_contrast",
            self.min_contrast,
            0 <= self.min_contrast <= 1,
            "a cosine distance in [0, 1]",
        )
        _check("contrast_s", self.contrast_s, self.contrast_s > 0, "a contrast window > 0 seconds")
        _check(
            "inclinations", self.inclinations, isinstance(self.inclinations, bool), "true or false"
        )
        _check(
            "speed_max",
            self.speed_max,
            self.speed_max >= 0,
            "a speed >= 0 rad/s (0: no speed columns)",
        )
        _check("speed_lag_s", self.speed_lag_s, self.speed_lag_s > 0, "a lag > 0 seconds")
        _check(
            "root_speed_max",
            self.root_speed_max,
            self.root_speed_max >= 0,
            "a speed >= 0 body scales/s (0: no root-speed columns)",
        )
        _check("root_jump", self.root_jump, self.root_jump > 0, "a speed > 0 body scales/s")
        _check(
            "novelty",
            self.novelty,
            0 <= self.novelty <= 1,
            "a cosine distance in [0, 1] (0: no novelty check)",
        )
        _check(
            "peak_rule",
            self.peak_rule,
            self.peak_rule in PEAK_RULES,
            " or ".join(repr(r) for r in PEAK_RULES),
        )
        e = self.early_delay_s
        _check(
            "early_delay_s",
            e,
            e is None
            or (isinstance(e, numbers.Real) and not isinstance(e, bool) and 0 <= e < self.delay_s),
            "None or 0 (one stage) or a delay >= 0 and < delay_s seconds",
        )
        o = self.onset_mads
        _check(
            "onset_mads",
            o,
            o is None or (isinstance(o, numbers.Real) and not isinstance(o, bool) and 0 < o < 100),
            "None (off) or a number of MADs > 0",
        )
        _check(
            "onset_rises",
            self.onset_rises,
            isinstance(self.onset_rises, int)
            and not isinstance(self.onset_rises, bool)
            and 1 <= self.onset_rises <= 20,
            "an integer number of windows in [1, 20]",
        )
        _check("onset_lead_s", self.onset_lead_s, 0 <= self.onset_lead_s <= 5, "0-5 seconds")
        _check("onset_gap_s", self.onset_gap_s, 0 < self.onset_gap_s <= 10, "0-10 seconds")

    @property
    def n_features(self) -> int:
        """Columns of a feature frame: 8 bone angles, plus 9 inclinations when enabled, plus
        the 2 root-speed columns when ``root_speed_max > 0``."""
        return (17 if self.inclinations else 8) + self.root_columns

    @property
    def root_columns(self) -> int:
        """How many of a feature frame's last columns are root speeds (LOF only): 2 or 0."""
        return 2 if self.root_speed_max > 0 else 0

    def histogram_columns(self, n_features: int) -> int:
        """Columns histogrammed for ``n_features`` input columns: doubled by the speeds."""
        return 2 * n_features if self.speed_max > 0 else n_features

    def check_columns(self, n_features: int) -> int:
        """The first histogrammed columns the cut's localisation, contrast and novelty read:
        all but the root speeds and their speeds (see :func:`streamseg.online.speed_features.
        lof_columns` for the order)."""
        return self.histogram_columns(n_features - self.root_columns)

    @property
    def onset_on(self) -> bool:
        """Whether the early stage is the onset rule (``onset_mads`` set, no
        ``early_delay_s``)."""
        return self.onset_mads is not None and not self.early_delay_s

    @property
    def two_stage(self) -> bool:
        """Whether the detector emits pending cuts (the early stage or the onset rule)."""
        return bool(self.early_delay_s) or self.onset_on

    @classmethod
    def paper(cls, **overrides) -> LOFConfig:
        """Xing et al. (2015) as published, made causal: what researchers compare against.

        From the paper: 500-frame windows, step 45 (at 120 Hz; here in seconds), L = 10 bins
        over [0, pi], k = 20, cosine distance, the 8 bone angles of its Tables 1-2 (no
        inclinations, no speed or root-speed columns, no temporal exclusion), and the decision
        "the peaks of the LOF curve", located by Douglas-Peucker curve simplification, the cut at
        the peak window's centre (``refine_s = 0``). Every peak vertex is a cut (``peak_rule =
        "paper"``): no LOF floor (``min_score = 0``), no threshold above the curve's level, no
        minimum gap, no contrast or novelty confirmation; the paper states none.

        Ours, because the paper gives none or works offline: ``dp_tolerance = 0.02`` of the
        buffered curve's range (chosen on CMU 86_01 alone) and ``delay_s`` = 9.75 s (26
        windows, the smallest that lets the live rule see both sides of a peak); why:
        ``docs/decisions.md`` (Cuts, the paper preset). Offline and live cuts are equal.
        """
        values = dict(
            window_s=500 / 120,
            step_s=45 / 120,
            bins=10,
            k=20,
            exclusion=0.0,
            refine_s=0.0,
            onset_mads=None,
            inclinations=False,
            min_contrast=0.0,
            speed_max=0.0,
            novelty=0.0,
            peak_rule="paper",
            min_score=0.0,
            threshold_mads=0.0,
            root_speed_max=0.0,
            min_gap_s=0.0,
            dp_tolerance=PAPER_TOLERANCE,
            delay_s=(6 + 20) * 45 / 120,
        )
        values.update(overrides)
        return cls(**values)

    def frames(self, fps: float) -> dict:
        """Integer frame/window counts for a stream at ``fps``.

        Returns
        -------
        dict
            ``window``, ``step`` (frames), ``capacity``, ``delay``, ``early`` (0: one stage),
            ``min_gap`` (windows),
            ``min_valid``, ``exclusion``, ``refine`` (frames), ``history`` (frames the
            streaming detector keeps: the last window plus what cut localisation may look at)
            and ``speed_lag`` (frames).
        """

        _check("fps", fps, fps > 0, "a frame rate > 0")
        window = max(2, int(round(self.window_s * fps)))
        step = max(1, min(window, int(round(self.step_s * fps))))
        delay = max(1, int(round(self.delay_s * fps / step)))
        # the early stage (0: off); at a low rate it may round to the confirming delay
        early = 0 if not self.early_delay_s else max(1, int(round(self.early_delay_s * fps / step)))
        if early >= delay:
            raise ParameterError(
                f"early_delay_s={self.early_delay_s!r} is {early} windows at {fps:g} Hz, not "
                f"fewer than delay_s's {delay}: lower early_delay_s or raise delay_s"
            )
        onset_lead = 0
        if self.onset_on:  # the onset rule: early is the windows between onsets
            early = max(1, int(round(self.onset_gap_s * fps / step)))
            onset_lead = int(round(self.onset_lead_s * fps / step))
        # the peak rule needs delay windows on both sides of the window it decides
        capacity = max(self.k + 2, 2 * delay + 1, int(round(self.buffer_s * fps / step)))
        refine = int(round(self.refine_s * fps))
        # a cut is decided delay * step + window - 1 - window // 2 frames after its window's
        # centre; localisation looks refine + window frames before that centre
        contrast = max(1, int(round(self.contrast_s * fps)))
        # the contrast and the novelty check read contrast frames before/after the cut: held
        back = max(
            window if refine else 0, contrast if self.min_contrast > 0 or self.novelty > 0 else 0
        )
        history = window if back == 0 else delay * step + window + refine + back + 1
        _bounded(fps, "window", window, MAX_WINDOW_FRAMES, "frames", "window_s (--window)")
        _bounded(
            fps,
            "LOF buffer",
            capacity,
            MAX_BUFFER_WINDOWS,
            "windows",
            "buffer_s (--buffer), k (--k) or delay_s (--delay), or raise step_s (--step)",
        )
        _bounded(
            fps,
            "frame history",
            history,
            MAX_HISTORY_FRAMES,
            "frames",
            "delay_s (--delay), refine_s (--refine) or contrast_s (--contrast)",
        )
        return dict(
            window=window,
            step=step,
            capacity=capacity,
            delay=delay,
            early=early,
            onset_lead=onset_lead,
            min_gap=int(round(self.min_gap_s * fps / step)),
            exclusion=int(round(self.exclusion * window)),
            min_valid=max(1, math.ceil(self.min_valid * window - 1e-9)),
            refine=refine,
            contrast=contrast,
            history=history,
            speed_lag=max(1, int(round(self.speed_lag_s * fps))),
        )


# Bounds on what one detector may hold, far above any sensible setting (the defaults at 10 kHz
# need a 10,000-frame window, 6,000 buffered windows): beyond them a typo (``--fps 1e9``,
# ``--buffer 1e9``) would be an allocation of gigabytes, refused here in one line instead.
MAX_WINDOW_FRAMES = 1 << 20
MAX_BUFFER_WINDOWS = 1 << 17
MAX_HISTORY_FRAMES = 1 << 23


def _bounded(fps, what, value, limit, unit, lower) -> None:
    if value > limit:
        raise ParameterError(
            f"at {fps:g} Hz these settings make a {what} of {value:,} {unit}, more than the "
            f"{limit:,} one detector holds: check the frame rate (--fps) or lower {lower}"
        )


def feature_width(config: LOFConfig, n_features) -> int:
    """Columns per frame a segmenter takes: ``n_features`` (validated) or ``config.n_features``."""
    if n_features is None:
        return config.n_features
    if (
        isinstance(n_features, bool)
        or not isinstance(n_features, numbers.Integral)
        or n_features < 1
    ):
        raise ParameterError(f"n_features={n_features!r} is invalid: expected an int >= 1")
    if n_features <= config.root_columns:
        raise ParameterError(
            f"n_features={n_features!r} is invalid: the last {config.root_columns} columns are "
            f"root speeds (root_speed_max={config.root_speed_max:g}); expected more than "
            f"{config.root_columns}, or LOFConfig(root_speed_max=0)"
        )
    return int(n_features)


def width_message(shape, d: int, config: LOFConfig, n_features, row: bool = False) -> str:
    """The error for features of the wrong width (``row``: one frame), with the fix when the
    config chose the width."""
    name, want = ("angles_row", f"({d},)") if row else ("angles", f"(n_frames, {d})")
    msg = f"{name} has shape {shape}; expected {want}"
    if n_features is not None:
        return msg
    msg += (
        f": the config's features, streamseg.skeleton.bone_angles(..., "
        f"inclinations={config.inclinations})"
    )
    if config.root_columns:
        msg += (
            " then the 2 root-speed columns (streamseg.offline.lof_features(recording) makes "
            "both; LOFConfig(root_speed_max=0) takes the bone features alone)"
        )
    other = not config.inclinations
    if (
        len(shape) in (1, 2)
        and shape[-1]
        == LOFConfig(inclinations=other, root_speed_max=config.root_speed_max).n_features
    ):
        msg += f"; {shape[-1]} columns are for LOFConfig(inclinations={other})"
    return msg
