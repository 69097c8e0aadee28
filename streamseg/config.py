"""Frozen configuration dataclasses, validated once at construction.

Each area keeps its config in its own section below; CLI flags and TOML keys map 1:1 onto the
fields. Times are in seconds so one configuration serves 30, 100 and 120 Hz streams.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from streamseg.exceptions import ParameterError


def _check(name: str, value, ok: bool, expected: str) -> None:
    """Raise a ParameterError naming the field, the value and what was expected."""
    if not ok:
        raise ParameterError(f"{name}={value!r} is invalid: expected {expected}")


def config_from_dict(cls, values: dict):
    """Build config ``cls`` from a mapping (e.g. a TOML table), rejecting unknown keys."""
    known = {f.name for f in fields(cls)}
    unknown = sorted(set(values) - known)
    if unknown:
        raise ParameterError(
            f"unknown {cls.__name__} option(s) {', '.join(unknown)}; "
            f"known: {', '.join(sorted(known))}"
        )
    return cls(**values)


# --- LOF (issue 3) ---------------------------------------------------------------------------


@dataclass(frozen=True)
class LOFConfig:
    """Sliding-window histogram + Local Outlier Factor cut detection (issue 3).

    Times are in seconds and converted to frames with the stream's rate, so one configuration
    serves 30, 100 and 120 Hz streams. The defaults were chosen on two recordings only (CMU 86_01
    and 14_14, see ``benchmarks/lof_accuracy.py``) and are held fixed for every other one;
    :meth:`paper` gives the settings of Xing et al. (2015).

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
    """

    window_s: float = 1.0
    step_s: float = 0.125
    bins: int = 10
    k: int = 10
    buffer_s: float = 75.0
    delay_s: float = 1.0
    threshold_mads: float = 3.0
    min_score: float = 1.2
    dp_tolerance: float = 0.1
    min_gap_s: float = 1.0
    min_valid: float = 0.5
    exclusion: float = 1.0

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

    @classmethod
    def paper(cls, **overrides) -> LOFConfig:
        """Xing et al. (2015): 500-frame windows, step 45 at 120 Hz, L = 10 bins, k = 20.

        The paper states no peak threshold; the adaptive rule is kept with its defaults.
        """
        values = dict(window_s=500 / 120, step_s=45 / 120, bins=10, k=20, exclusion=0.0)
        values.update(overrides)
        return cls(**values)

    def frames(self, fps: float) -> dict:
        """Integer frame/window counts for a stream at ``fps``.

        Returns
        -------
        dict
            ``window``, ``step`` (frames), ``capacity``, ``delay``, ``min_gap`` (windows),
            ``min_valid`` and ``exclusion`` (frames).
        """
        import math

        _check("fps", fps, fps > 0, "a frame rate > 0")
        window = max(2, int(round(self.window_s * fps)))
        step = max(1, min(window, int(round(self.step_s * fps))))
        delay = max(1, int(round(self.delay_s * fps / step)))
        # the peak rule needs delay windows on both sides of the window it decides
        capacity = max(self.k + 2, 2 * delay + 1, int(round(self.buffer_s * fps / step)))
        return dict(
            window=window,
            step=step,
            capacity=capacity,
            delay=delay,
            min_gap=int(round(self.min_gap_s * fps / step)),
            exclusion=int(round(self.exclusion * window)),
            min_valid=max(1, math.ceil(self.min_valid * window - 1e-9)),
        )


# --- ACA (issue 4) ---------------------------------------------------------------------------


# --- daemon (issue 5) ------------------------------------------------------------------------


@dataclass(frozen=True)
class DaemonConfig:
    """Options of ``streamseg serve`` (TOML table ``[daemon]``; flags of the same names).

    Attributes
    ----------
    ingest, publish, control : str
        ZeroMQ endpoints the daemon binds: PULL for frame packets, PUB for events, REP for
        control requests (``control=""`` disables it). Loopback by default.
    max_streams : int
        Streams held at once; a further announcement gets an ``error`` event.
    idle_timeout : float
        Seconds without a packet after which a stream is closed (reason ``idle``).
    relabel_interval, relabel_history : float
        Relabel each stream every R seconds of its own time over its last H seconds
        (``relabel_interval=0`` turns relabelling off). H also bounds each stream's buffer.
    heartbeat : float
        Seconds between ``stats`` events (0: none).
    max_packet_frames : int
        Largest frame count accepted in one packet (bounds memory per message).
    drain : int
        Most packets taken from the socket before the per-stream computation runs once on
        all of them (the vectorised path; larger is faster, smaller has lower latency).
    hwm : int
        ZeroMQ high-water marks (messages) of ingest and publish sockets.
    default_skeleton, default_fps : str, float
        An ASF file whose skeleton (and this rate) serves streams that send frames without
        an announcement; ``""`` requires announcements.
    shutdown_relabel : float
        Seconds at most spent on final relabels at shutdown (then ``closed`` events follow).
    """

    ingest: str = "tcp://127.0.0.1:5560"
    publish: str = "tcp://127.0.0.1:5561"
    control: str = "tcp://127.0.0.1:5562"
    max_streams: int = 2000
    idle_timeout: float = 60.0
    relabel_interval: float = 5.0
    relabel_history: float = 20.0
    heartbeat: float = 1.0
    max_packet_frames: int = 12000
    drain: int = 2000
    hwm: int = 200000
    default_skeleton: str = ""
    default_fps: float = 120.0
    shutdown_relabel: float = 5.0

    def __post_init__(self):
        for name in ("ingest", "publish"):
            v = getattr(self, name)
            _check(
                name,
                v,
                isinstance(v, str) and "://" in v,
                "a ZeroMQ endpoint like tcp://127.0.0.1:5560",
            )
        _check(
            "control",
            self.control,
            isinstance(self.control, str) and (self.control == "" or "://" in self.control),
            'an endpoint or "" (off)',
        )
        for name in ("max_streams", "max_packet_frames", "drain", "hwm"):
            v = getattr(self, name)
            _check(
                name,
                v,
                isinstance(v, int) and not isinstance(v, bool) and v >= 1,
                "an integer >= 1",
            )
        for name in ("idle_timeout", "relabel_history", "default_fps"):
            v = getattr(self, name)
            _check(
                name,
                v,
                isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0,
                "a number > 0 (seconds or Hz)",
            )
        for name in ("relabel_interval", "heartbeat", "shutdown_relabel"):
            v = getattr(self, name)
            _check(
                name,
                v,
                isinstance(v, (int, float)) and not isinstance(v, bool) and v >= 0,
                "a number >= 0 (seconds; 0 turns it off)",
            )
        _check(
            "default_skeleton",
            self.default_skeleton,
            isinstance(self.default_skeleton, str),
            'a path to an ASF file or ""',
        )


# --- repetitions (issue 6) -------------------------------------------------------------------


@dataclass(frozen=True)
class RepetitionConfig:
    """Repetition segmentation (Wang et al. 2015) offline and live.

    Parameters
    ----------
    position_noise : float
        UKF measurement noise std in body-scale units (1 = the median long-bone length);
        0.05 is about 1.5 cm on an adult: between optical mocap and Kinect.
    angle_speed : float
        UKF random-walk std of each joint angle, rad per second.
    length_speed : float
        UKF random-walk std of log bone lengths per second (passes 1-2).
    ukf_passes : int
        4 (paper) or 2 (skip the fixed-length passes).
    torso_cutoff_hz : float
        Low-pass applied to the points defining the torso frame.
    power_ratio : float
        theta: the selected parameters hold this share of the power at the primary frequency.
    min_cycles : float
        Lowest primary frequency, in cycles per sequence.
    max_frequency_hz : float
        Highest primary frequency (repetitions per second).
    fft_pad : int
        Zero-padding factor of the spectra.
    band_width_cycles : float
        Width of the band-pass around the primary frequency, cycles per sequence (paper: 3).
    filter_order : int
        Butterworth order.
    window_fraction : float
        Candidate-search window (eq. 10) as a fraction of the period; windows overlap by half.
    k_max : int
        Largest K tried by the adaptive k-means (paper: 10).
    kmeans_restarts : int
    seed : int
    tie_tolerance : float
        Groups whose eq. 14 span is within this fraction of the best count as tied.
    edge_fraction : float
        A stretch before the first / after the last boundary is a repetition when at least this
        many periods long.
    buffer_seconds : float
        Live: analysed history.
    hop_seconds : float
        Live: analysis interval.
    repetitive_ratio : float
        Live: the buffer counts as repetitive when the band around the primary frequency holds
        at least this share of the total (detrended) angle power above ``min_cycles``.
    """

    position_noise: float = 0.05
    angle_speed: float = 4.0
    length_speed: float = 0.02
    ukf_passes: int = 4
    torso_cutoff_hz: float = 2.0
    power_ratio: float = 0.9
    min_cycles: float = 2.0
    max_frequency_hz: float = 3.0
    fft_pad: int = 4
    band_width_cycles: float = 3.0
    filter_order: int = 2
    window_fraction: float = 0.5
    k_max: int = 10
    kmeans_restarts: int = 5
    seed: int = 0
    tie_tolerance: float = 0.05
    edge_fraction: float = 0.5
    buffer_seconds: float = 12.0
    hop_seconds: float = 0.5
    repetitive_ratio: float = 0.5

    def __post_init__(self):
        for name in (
            "position_noise",
            "angle_speed",
            "torso_cutoff_hz",
            "max_frequency_hz",
            "band_width_cycles",
            "buffer_seconds",
            "hop_seconds",
        ):
            v = getattr(self, name)
            _check(name, v, isinstance(v, (int, float)) and v > 0, "a number > 0")
        _check(
            "length_speed",
            self.length_speed,
            isinstance(self.length_speed, (int, float)) and self.length_speed >= 0,
            "a number >= 0",
        )
        _check("ukf_passes", self.ukf_passes, self.ukf_passes in (2, 4), "2 or 4")
        for name in ("power_ratio", "repetitive_ratio", "window_fraction"):
            v = getattr(self, name)
            _check(name, v, isinstance(v, (int, float)) and 0 < v <= 1, "a number in (0, 1]")
        _check(
            "min_cycles",
            self.min_cycles,
            isinstance(self.min_cycles, (int, float)) and self.min_cycles >= 1,
            "a number >= 1 (cycles per sequence)",
        )
        for name in ("fft_pad", "filter_order", "kmeans_restarts"):
            v = getattr(self, name)
            _check(name, v, isinstance(v, int) and v >= 1, "an integer >= 1")
        _check(
            "k_max",
            self.k_max,
            isinstance(self.k_max, int) and 2 <= self.k_max <= 50,
            "an integer in 2..50",
        )
        _check("seed", self.seed, isinstance(self.seed, int), "an integer")
        _check(
            "tie_tolerance",
            self.tie_tolerance,
            isinstance(self.tie_tolerance, (int, float)) and 0 <= self.tie_tolerance < 1,
            "a number in [0, 1)",
        )
        _check(
            "edge_fraction",
            self.edge_fraction,
            isinstance(self.edge_fraction, (int, float)) and 0 < self.edge_fraction <= 1.5,
            "a number in (0, 1.5]",
        )
        _check(
            "hop_seconds",
            self.hop_seconds,
            self.hop_seconds < self.buffer_seconds,
            f"less than buffer_seconds={self.buffer_seconds}",
        )
