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

    @classmethod
    def paper(cls, **overrides) -> LOFConfig:
        """Xing et al. (2015): 500-frame windows, step 45 at 120 Hz, L = 10 bins, k = 20.

        The paper states no peak threshold; the adaptive rule is kept with its defaults. The
        cut is the peak window's centre (``refine_s = 0``), as in the paper.
        """
        values = dict(window_s=500 / 120, step_s=45 / 120, bins=10, k=20, exclusion=0.0,
                      refine_s=0.0)
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
        import math

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


# --- ACA (issue 4) ---------------------------------------------------------------------------


@dataclass(frozen=True)
class ACAConfig:
    """Aligned Cluster Analysis relabelling (issue 4); lengths in seconds.

    Defaults were chosen on one recording, CMU 86_01 (``benchmarks/aca_mocap.py``), among a
    handful of round settings, and are held fixed for every other one.

    Attributes
    ----------
    n_clusters : int
        Number of actions k.
    min_len, max_len : float
        Segment lengths in seconds (a segment is one or a few cycles of an action; a run of
        one action is several consecutive segments with one label).
    kernel : {"gaussian", "equality"}
        Frame kernel; "equality" is the paper's sigma -> 0 limit for discrete data.
    sigma : float or None
        Gaussian bandwidth in feature units; None = rule from the data
        (``streamseg.offline.dtak.default_sigma``).
    n_init : int
        Random restarts; the lowest objective wins.
    max_iter : int
        Cap on coordinate-descent steps per restart.
    init : {"random", "propagated"}
        Initialization of the first restart (section 4.2); the others are random.
    k_reduce : int or None
        Temporal reduction into this many k-means frame classes (section 4.1); None = off.
    reduce_cap : float
        At most this many seconds of consecutive same-class frames become one reduced frame.
    hierarchical : bool
        Two-level HACA instead of ACA.
    fine_clusters : int
        HACA fine level: number of primitives.
    fine_min_len, fine_max_len : float
        HACA fine level: primitive lengths in seconds.
    coarse_kernel : {"labels", "dtak"}
        HACA coarse level: kernel between primitives, their DTAK or the equality of their
        cluster labels (see ``streamseg.offline.haca``).
    random_state : int or None
        Seed (fixed by default so a window gives the same answer twice).
    """

    n_clusters: int = 4
    min_len: float = 0.5
    max_len: float = 2.0
    kernel: str = "gaussian"
    sigma: float | None = None
    n_init: int = 10
    max_iter: int = 50
    init: str = "random"
    k_reduce: int | None = 20
    reduce_cap: float = 1 / 6
    hierarchical: bool = False
    fine_clusters: int = 10
    fine_min_len: float = 1 / 12
    fine_max_len: float = 0.25
    coarse_kernel: str = "dtak"
    random_state: int | None = 0

    def __post_init__(self):
        def is_int(v):
            return isinstance(v, int) and not isinstance(v, bool)

        _check("n_clusters", self.n_clusters, is_int(self.n_clusters) and self.n_clusters >= 1,
               "an integer >= 1")
        _check("min_len", self.min_len, isinstance(self.min_len, (int, float))
               and self.min_len > 0, "a length > 0 seconds")
        _check("max_len", self.max_len, isinstance(self.max_len, (int, float))
               and self.max_len >= self.min_len, f"a length >= min_len={self.min_len} seconds")
        _check("kernel", self.kernel, self.kernel in ("gaussian", "equality"),
               "'gaussian' or 'equality'")
        _check("sigma", self.sigma, self.sigma is None or (
            isinstance(self.sigma, (int, float)) and self.sigma > 0), "None or a number > 0")
        _check("n_init", self.n_init, is_int(self.n_init) and self.n_init >= 1, "an integer >= 1")
        _check("max_iter", self.max_iter, is_int(self.max_iter) and self.max_iter >= 1,
               "an integer >= 1")
        _check("init", self.init, self.init in ("random", "propagated"),
               "'random' or 'propagated'")
        _check("k_reduce", self.k_reduce, self.k_reduce is None or (
            is_int(self.k_reduce) and self.k_reduce >= 2), "None or an integer >= 2")
        _check("reduce_cap", self.reduce_cap, isinstance(self.reduce_cap, (int, float))
               and self.reduce_cap > 0, "a duration > 0 seconds")
        _check("hierarchical", self.hierarchical, isinstance(self.hierarchical, bool),
               "True or False")
        _check("fine_clusters", self.fine_clusters,
               is_int(self.fine_clusters) and self.fine_clusters >= 1, "an integer >= 1")
        _check("fine_min_len", self.fine_min_len, isinstance(self.fine_min_len, (int, float))
               and self.fine_min_len > 0, "a length > 0 seconds")
        _check("fine_max_len", self.fine_max_len, isinstance(self.fine_max_len, (int, float))
               and self.fine_max_len >= self.fine_min_len,
               f"a length >= fine_min_len={self.fine_min_len} seconds")
        _check("coarse_kernel", self.coarse_kernel, self.coarse_kernel in ("labels", "dtak"),
               "'labels' or 'dtak'")
        _check("random_state", self.random_state, self.random_state is None
               or is_int(self.random_state), "None or an integer seed")


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
    drain, drain_frames : int
        Most packets, and frames, taken from the socket before the per-stream computation
        runs once on all of them (the vectorised path; larger is faster, smaller has lower
        latency).
    ingest_hwm, hwm : int
        ZeroMQ high-water marks (messages) of the ingest and the publish socket. The ingest
        queue is what bounds the daemon's memory under overload (senders then wait): at most
        ``ingest_hwm`` packets are buffered, e.g. 2000 x 60 frames x 31 joints = 90 MB.
    default_skeleton, default_fps : str, float
        An ASF file whose skeleton (and this rate) serves streams that send frames without
        an announcement; ``""`` requires announcements.
    shutdown_relabel : float
        Seconds at most spent on final relabels at shutdown (then ``closed`` events follow).
    repetitions : bool
        Count repetitions live (``rep`` events, issue 6's RepetitionCounter). Off by default:
        it takes 0.5-1 ms of CPU per frame (6-12% of a core per 120 Hz stream).
    relabel_processes : int
        0: relabel in a thread of the daemon (ACA's Python parts share the GIL with ingest);
        N > 0: the worker thread hands each job to a pool of N processes.
    receive_thread : bool
        Receive and decode packets in a thread of their own, overlapping the detector's
        GIL-free kernels. Faster for one high-rate stream of small packets, slower with many
        streams (each GIL hand-back after a kernel call waits for the receiver), hence off.
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
    drain_frames: int = 4096
    ingest_hwm: int = 2000
    hwm: int = 100000
    default_skeleton: str = ""
    default_fps: float = 120.0
    shutdown_relabel: float = 5.0
    repetitions: bool = False
    relabel_processes: int = 0
    receive_thread: bool = False

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
        _check("receive_thread", self.receive_thread, isinstance(self.receive_thread, bool),
               "true or false")
        _check("relabel_processes", self.relabel_processes,
               type(self.relabel_processes) is int and self.relabel_processes >= 0,
               "an integer >= 0")
        for name in ("max_streams", "max_packet_frames", "drain", "drain_frames", "hwm",
                     "ingest_hwm"):
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
        _check("repetitions", self.repetitions, isinstance(self.repetitions, bool),
               "true or false")


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
    estimate_noise : bool
        Offline: raise ``position_noise`` to the noise estimated from the recording's
        frame-to-frame jitter (:func:`streamseg.ukf_model.estimate_noise`) when larger.
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
    merge_phase : float
        k-means clusters whose mean cos(phase) vectors are closer than this (RMS; opposite
        phases are ~2 apart) are merged into one group before eq. 14 (0 = never merge).
    refine_fraction : float
        Each chosen boundary moves to the nearest velocity minimum of the selected parameters
        low-passed at ``refine_band`` x the primary frequency, within this many periods
        (0 = off: the paper's boundaries).
    refine_band : float
        Low-pass cut-off of that refinement, in multiples of the primary frequency.
    buffer_seconds : float
        Live: analysed history.
    hop_seconds : float
        Live: analysis interval.
    repetitive_ratio : float
        Live: the buffer counts as repetitive when the band around the primary frequency holds
        at least this share of the total (detrended) angle power above ``min_cycles``.
    """

    position_noise: float = 0.05
    angle_speed: float = 8.0
    estimate_noise: bool = True
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
    merge_phase: float = 0.6
    refine_fraction: float = 0.2
    refine_band: float = 4.0
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
            "merge_phase",
            self.merge_phase,
            isinstance(self.merge_phase, (int, float)) and 0 <= self.merge_phase <= 2,
            "a number in [0, 2]",
        )
        _check(
            "refine_fraction",
            self.refine_fraction,
            isinstance(self.refine_fraction, (int, float)) and 0 <= self.refine_fraction < 0.5,
            "a number in [0, 0.5)",
        )
        _check(
            "refine_band",
            self.refine_band,
            isinstance(self.refine_band, (int, float)) and self.refine_band >= 1,
            "a number >= 1",
        )
        _check(
            "hop_seconds",
            self.hop_seconds,
            self.hop_seconds < self.buffer_seconds,
            f"less than buffer_seconds={self.buffer_seconds}",
        )
