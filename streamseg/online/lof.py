"""Streaming LOF cut detector: bone-angle frames in, :class:`CutEvent` events out."""

from __future__ import annotations

import numpy as np

from streamseg._kernels import frames_in
from streamseg._kernels import lof_buffer as _kb
from streamseg._kernels import lof_decide as _kd
from streamseg._kernels import lof_stream as _ks
from streamseg._kernels import stream_features as _sf
from streamseg.config import LOFConfig
from streamseg.config.lof import feature_width, width_message
from streamseg.exceptions import ParameterError
from streamseg.online.lof_events import event_room, kernel_events, new_event_arrays
from streamseg.online.root_speed import NO_ROOT
from streamseg.online.speed_features import NO_SPEEDS, SpeedColumns
from streamseg.state import Stateful


class StreamingLOFSegmenter(Stateful):
    """Online version of :class:`streamseg.offline.LOFSegmenter`, bounded memory.

    Each frame's features are followed by their angular speeds (``config.speed_max``,
    :mod:`streamseg.online.speed_features`, causal), and both are histogrammed. With
    ``config.root_speed_max > 0`` a frame's last two columns are the root speeds
    (:mod:`streamseg.online.root_speed`): they enter the windows' histograms, so the LOF, but
    not the histograms that place and confirm a cut (``config.check_columns``). Per frame, the
    window histogram is updated in O(bins) (the entering frame is added, the leaving one
    removed). Each completed window's count vector enters a ring buffer of
    ``capacity`` windows (``config.buffer_s`` seconds) whose LOF values are maintained
    incrementally (Pokrajac et al. 2007): on insert and on evicting the oldest window only the
    points whose neighbour list, reachability or lrd change are recomputed (once per window,
    for the eviction and the insert together), found through reverse lists (which lists
    hold each window) instead of passes over the buffer. Each window keeps its ``3 * k``
    nearest windows as candidates, so an eviction almost never forces an O(capacity) rescan for a
    new k-th neighbour; the median and MAD of the threshold use selection, not sorting.
    Window ``w`` is decided once, when window ``w + delay`` is complete: it is a cut when it is a
    peak vertex of the Douglas-Peucker simplification of the LOF curve over windows ``w - delay ..
    w + delay`` and reaches ``max(min_score, median + threshold_mads * 1.4826 * MAD)`` of the
    buffered curve, at least ``min_gap`` windows after the previous cut. The cut frame is then
    moved from the window's centre to the frame within ``refine`` frames (``refine_s``) where the
    count histograms of the ``window`` frames before and after it differ most (cosine distance),
    among the frames already seen, and confirmed when at least ``window`` frames after it have
    been seen and the histograms of the ``contrast`` frames before it (since the previous cut at
    most) and after it differ by ``min_contrast``, and when the histograms of the whole current
    segment (since the previous cut, as far back as the frame ring holds) and of the
    ``contrast`` frames after it differ by ``novelty`` (see :class:`LOFConfig`). The offline
    segmenter makes these same decisions over a whole file.
    (The frame ring holds ``history`` frames, enough without NaN-dropped windows; after drops
    the search may be clipped to the frames still held.)

    Latency: window ``w`` is decided on the last frame of window ``w + delay``, that is
    ``delay * step + window - 1 - window // 2`` frames after the centre of ``w``; localisation
    moves the cut by at most ``refine`` frames either way, so the worst-case latency is
    ``delay * step + window - 1 - window // 2 + refine`` frames (:meth:`latency_frames`; with
    the defaults at 120 Hz: 8 * 24 + 210 - 1 - 105 + 96 = 392 frames, 3.27 s; the decision
    itself is 296 frames, 2.47 s, after the peak window's centre; the median over the labelled
    recordings is 2.3 s, ``benchmarks/lof_latency.py``). This holds when no window is dropped
    for NaN frames; every dropped window delays the decision by one more ``step``.
    :meth:`finish` decides the last ``delay`` windows at the end.

    NaN policy: a frame with any non-finite angle is skipped (counted in ``n_nan_frames_``)
    and enters no histogram; it still advances the frame clock. A window with fewer than
    ``min_valid`` valid frames is not inserted (counted in ``n_dropped_windows_``).

    Memory: fixed at construction, ``capacity * (2 * d * bins + 78 * k + 89)`` +
    ``(d + 1) * history`` bytes, ``d`` the histogrammed columns (``n_features``, doubled by
    the speed columns of ``config.speed_max``: 38 by default, 34 without the root speeds),
    ``history = delay * step + window + refine + max(window, contrast) + 1`` frames, plus
    ``(lag + 2) * n_features`` floats for the speeds (defaults at 120 Hz: 375 windows and 739
    frames, 388 kB per stream, 388 MB for 1,000 streams; without the root speeds 366 kB,
    without any speeds 273 kB; the ``3 * k`` candidates take 113 kB, their reverse lists
    37 kB).

    Parameters
    ----------
    config : LOFConfig
    fps : float
    n_features : int or None
        Columns per frame; None: ``config.n_features`` (the bone features). Any other matrix
        of angles in [0, pi] works the same way (e.g. a subset of the bone features).
    """

    def __init__(
        self, config: LOFConfig | None = None, fps: float = 120.0, n_features: int | None = None
    ):
        self.config = LOFConfig() if config is None else config
        if not fps > 0:
            raise ParameterError(f"fps={fps!r} is invalid: expected a frame rate > 0")
        self.n_features = feature_width(self.config, n_features)
        self._explicit_width = n_features
        self.fps = float(fps)
        g = self.geometry = self.config.frames(self.fps)
        c = self.config
        # the histogrammed columns: the features, then their angular speeds (speed_max > 0)
        self._cols = c.histogram_columns(self.n_features)
        self._speeds = SpeedColumns(c, self.fps, self.n_features) if c.speed_max > 0 else None
        n, k, d, w = g["capacity"], c.k, self._cols * c.bins, g["window"]
        # in the order of the kernel's GEO_* and P_* slots
        self._geo = np.array(
            [
                c.bins,
                w,
                g["step"],
                g["min_valid"],
                k,
                g["exclusion"],
                g["refine"],
                g["contrast"],
                c.check_columns(self.n_features),
            ],
            dtype=np.int64,
        )
        # the kernel reads a negative MAD count as the paper's rule (no threshold)
        mads = c.threshold_mads if c.peak_rule == "adaptive" else -1.0
        self._p = np.array(
            [
                g["delay"],
                c.dp_tolerance,
                mads,
                c.min_score,
                g["min_gap"],
                c.min_contrast,
                c.novelty,
                g["early"],
                c.onset_mads if c.onset_on else 0.0,
                c.onset_rises,
                g["onset_lead"],
            ],
            dtype=np.float64,
        )
        assert self._geo.size == _kd.GEO_SIZE and self._p.size == _kd.P_SIZE
        # np.zeros/np.empty are lazily committed by the OS, so creating many streams is cheap
        self._st = _kd.new_state()
        # frame bins of the last `history` frames: the sliding histogram removes frame f - w,
        # cut localisation reads back to refine + w frames before a peak window's centre
        self._rb = np.zeros((g["history"], self._cols), dtype=np.int8)
        self._rv = np.zeros(g["history"], dtype=np.uint8)
        self._cur = np.zeros(d, dtype=np.int64)
        # counts <= window frames as int16, their dot products summed in int32: exact while
        # columns * window**2 < 2**31 (7,517 frames for the default 38 columns, 62 s at 120 Hz)
        longest = int(np.sqrt((2**31 - 1) / self._cols))
        if w > longest:
            raise ParameterError(
                f"window of {w} frames is too long: at most {longest} frames "
                f"with {self._cols} histogram columns (lower window_s)"
            )
        self._vecs = np.zeros((n, d), dtype=np.int16)
        self._seqs = np.full(n, -1, dtype=np.int64)
        self._centres = np.zeros(n, dtype=np.int64)
        # the pending early cuts (window, frame): they lie within delay - early + min_gap
        # windows of the window the final stage decides next
        self._pend = np.zeros(
            (g["delay"] + g["min_gap"] + g["onset_lead"] + 2 if g["early"] else 0, 2),
            dtype=np.int64,
        )
        self._allocate_derived()

    STATE_VERSION = 2  # 2: the two-stage decision (_pend), the decision's columns in _geo
    # Recomputed from the rest (the window vectors, their sequence numbers and centres) or
    # scratch: a state need not store them (streamseg.state), and they are half of what
    # changes between two checkpoints of a full stream (scattered list updates)
    _transient = (
        "_norms",
        "_nn_idx",
        "_nn_d",
        "_nn_key",
        "_nn_cnt",
        "_trunc",
        "_lrd",
        "_lof",
        "_mark",
        "_rev",
        "_rev_cnt",
        "_queue",
        "_gate",
        "_work",
        "_curve",
        "_keep",
        "_stack",
        "_left",
        "_right",
        "_ev",
        "_kernel_groups",
        "_kernel_arrays",
    )

    def _allocate_derived(self) -> None:
        g, k, n = self.geometry, self.config.k, self._seqs.shape[0]
        d = self._vecs.shape[1]
        self._ev = None  # the event arrays, reused (_event_arrays)
        self._left = np.zeros(d, dtype=np.int64)
        self._right = np.zeros(d, dtype=np.int64)
        self._norms = np.zeros(n)
        # 3k nearest candidates per window: an eviction then almost never empties a list
        # below k, which forces an O(n d) rescan of the buffer (86_01 cycled, full buffer:
        # 0.46 rescans per eviction with 2k, none with 3k; 3k is 4 % faster in all)
        kk = 3 * k
        self._nn_idx = np.zeros((n, kk), dtype=np.int32)
        self._nn_d = np.zeros((n, kk))
        self._nn_key = np.zeros((n, kk), dtype=np.int64)
        self._nn_cnt = np.zeros(n, dtype=np.int64)
        self._trunc = np.zeros(n, dtype=np.uint8)
        self._lrd = np.zeros(n)
        self._lof = np.zeros(n)
        self._mark = np.zeros(n, dtype=np.int64)
        # which lists hold each window: an update visits those instead of every list; a
        # window held by more than 3 * kk (none on 86_01, 02_01, 02_05: at most 38 of 45) is
        # looked for in every list
        self._rev = np.zeros((n, 3 * kk), dtype=np.int16 if n < 1 << 15 else np.int32)
        self._rev_cnt = np.zeros(n, dtype=np.int32)
        self._queue = np.zeros(n + 1, dtype=np.int32)
        self._gate = np.zeros(n)  # see streamseg._kernels.lof_buffer
        self._work = np.zeros(n)
        self._curve = np.zeros(n)
        self._keep = np.zeros(2 * g["delay"] + 1, dtype=np.uint8)
        self._stack = np.zeros(4 * (2 * g["delay"] + 1) + 4, dtype=np.int64)
        # the kernel's arrays in its groups, built once: a few microseconds a packet
        self._kernel_groups = (
            (self._rb, self._rv, self._cur, self._left, self._right),
            self._buffer(),
            (self._work, self._curve, self._keep, self._stack),
        )
        # the same arrays one by one, as push_block takes them
        self._kernel_arrays = tuple(a for group in self._kernel_groups for a in group)

    def _restored(self) -> None:
        self._rebuild_derived()

    def _rebuild_derived(self) -> None:
        """Recompute :attr:`_transient` from the buffered windows (after a restore):
        the same LOF values and the same later cuts as the state it was saved from
        (:func:`streamseg._kernels.lof_buffer.ext_rebuild`). O(capacity^2 * columns * bins)."""
        self._allocate_derived()
        _kb.ext_rebuild(self._buffer(), self.config.k, int(self._geo[_kd.GEO_EXCLUSION]))

    # ---- feeding ---------------------------------------------------------------------------
    def learn_one(self, angles_row) -> list:
        """Feed one feature frame, shape (n_features,) radians (8 bone angles, then 9
        inclinations when ``config.inclinations``); return the cuts decided on it (with
        ``config.early_delay_s``, also the :class:`ConfirmEvent` and :class:`WithdrawEvent`
        that settle pending cuts)."""
        row = np.asarray(angles_row, dtype=np.float64)
        d = self.n_features
        if row.shape != (d,):
            raise ParameterError(
                width_message(row.shape, d, self.config, self._explicit_width, row=True)
            )
        return self._run(row.reshape(1, d))

    def learn_many(self, angles) -> list:
        """Feed feature frames, shape (n, n_features); same cuts as ``learn_one`` per row."""
        a = np.asarray(angles, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] != self.n_features:
            raise ParameterError(
                width_message(a.shape, self.n_features, self.config, self._explicit_width)
            )
        return self._run(np.ascontiguousarray(a))

    def learn_positions(self, positions: np.ndarray, bones: tuple, root=None):
        """Joint positions (n, J, 3) in: their bone features learned in one kernel call
        (:func:`streamseg._kernels.stream_features.push_block`), the same cuts as
        ``learn_many`` of the features (with the root speeds of ``root`` appended).

        Parameters
        ----------
        positions : ndarray, shape (n, J, 3)
        bones : tuple
            ``(parent, child, first, second, up)``: the bones' end points and the angle pairs
            of :func:`streamseg._kernels.bones.angles_kernel`
            (:meth:`streamseg.daemon.algorithms.Algorithms.prepare` resolves them per stream);
            ``m = len(first)`` features, ``m + 2`` columns with ``root`` must be
            ``n_features``.
        root : RootSpeed or None
            The stream's root-speed columns (:class:`streamseg.online.root_speed.RootSpeed`),
            advanced here.

        Returns
        -------
        angles : ndarray, shape (n, m)
            The features (without the root speeds).
        ok : ndarray of bool, shape (n,)
            Frames whose features are all finite.
        events : list
            As :meth:`learn_many`.
        """
        pos = frames_in(positions)
        width = bones[2].shape[0] + (0 if root is None else 2)
        if pos.ndim != 3 or pos.shape[2] != 3 or width != self.n_features:
            raise ParameterError(
                f"positions of shape {pos.shape} with {width} feature "
                f"columns: expected (n, J, 3) and {self.n_features} columns"
            )
        ev = self._event_arrays(pos.shape[0] // self.geometry["step"] + 2)
        angles, ok, n = _sf.push_block(
            pos,
            *bones,
            *(NO_ROOT if root is None else root.kernel_args()),
            *self._speed_args(),
            self._st,
            self._geo,
            self._p,
            *self._kernel_arrays,
            *ev,
            self._pend,
        )
        return angles, ok, kernel_events(n, ev)

    def _speed_args(self) -> tuple:
        return NO_SPEEDS if self._speeds is None else self._speeds.kernel_args()

    def finish(self) -> list:
        """End of stream: decide the windows still waiting for ``delay`` future windows (and
        settle every pending cut)."""
        ev = self._event_arrays(self.geometry["delay"] + 1)
        n = _ks.stream_finish(self._st, self._p, self._geo, *self._groups(), ev, self._pend)
        return kernel_events(n, ev)

    def _run(self, a: np.ndarray) -> list:
        if self._speeds is not None:
            a = self._speeds(a)
        ev = self._event_arrays(a.shape[0] // self.geometry["step"] + 2)
        n = _ks.stream_block(a, self._st, self._geo, self._p, *self._groups(), ev, self._pend)
        return kernel_events(n, ev)

    def _event_arrays(self, windows: int) -> tuple:
        """Event arrays with room for the events of ``windows`` decided windows."""
        m = event_room(windows, self.geometry["early"], self._pend.shape[0])
        ev = self._ev
        if ev is not None and ev[0].shape[0] >= m:  # read into events before the next call
            return ev
        ev = new_event_arrays(m)
        if m <= 64:  # kept for the next packets (a few frames each, live); not a huge one's
            self._ev = ev
        return ev

    def _groups(self) -> tuple:
        """The kernel's state arrays in its three groups: frame ring and counts, the LOF
        buffer (:mod:`streamseg._kernels.lof_buffer`), scratch."""
        return self._kernel_groups

    def _buffer(self) -> tuple:
        """The LOF buffer's arrays (:data:`streamseg._kernels.lof_buffer.FIELDS`)."""
        return tuple(getattr(self, "_" + name) for name in _kb.FIELDS)

    # ---- read-only views (never mutate state) ----------------------------------------------
    @property
    def n_frames_(self) -> int:
        """Frames fed so far (NaN frames included)."""
        return int(self._st[_kd.ST_FRAMES])

    @property
    def n_nan_frames_(self) -> int:
        """Frames skipped because an angle was NaN or infinite."""
        return int(self._st[_kd.ST_NAN_FRAMES])

    @property
    def n_dropped_windows_(self) -> int:
        """Windows not inserted because fewer than ``min_valid`` of their frames were valid."""
        return int(self._st[_kd.ST_DROPPED])

    @property
    def n_windows_(self) -> int:
        """Windows inserted into the LOF buffer so far (including evicted ones)."""
        return int(self._st[_kd.ST_NEXT_SEQ])

    @property
    def n_lof_updates_(self) -> int:
        """Total LOF recomputations done by the incremental updates (work statistic)."""
        return int(self._st[_kd.ST_RECOMPUTES])

    def _order(self) -> np.ndarray:
        size, nxt = int(self._st[_kd.ST_BUFFERED]), int(self._st[_kd.ST_NEXT_SEQ])
        return np.arange(nxt - size, nxt) % self._seqs.shape[0]

    def buffer_vectors(self) -> np.ndarray:
        """Count vectors of the buffered windows, oldest first, shape (size, columns * bins):
        ``columns`` is ``config.histogram_columns(n_features)`` (the speeds double it)."""
        return self._vecs[self._order()].astype(np.float64)

    def buffer_lof(self) -> np.ndarray:
        """Current LOF values of the buffered windows, oldest first, shape (size,)."""
        return self._lof[self._order()].copy()

    def buffer_centres(self) -> np.ndarray:
        """Centre frames of the buffered windows, oldest first, shape (size,)."""
        return self._centres[self._order()].copy()

    def decision_lag_frames(self) -> int:
        """Frames from a peak window's centre to the decision on it, without NaN drops."""
        g = self.geometry
        return g["delay"] * g["step"] + g["window"] - 1 - g["window"] // 2

    def latency_frames(self) -> int:
        """Worst-case latency (frames) from a cut frame to its emission, without NaN drops."""
        return self.decision_lag_frames() + self.geometry["refine"]


def warmup() -> None:
    """Compile (or load from cache) every kernel of the live detector, e.g. at daemon start
    (:func:`streamseg.offline.lof.warmup` covers the offline path too)."""
    from streamseg._kernels.histogram import bin_frames, contrast_at

    cfg = LOFConfig(window_s=0.1, step_s=0.05, k=2, buffer_s=0.5, delay_s=0.05)
    rng = np.random.default_rng(0)
    angles = rng.uniform(0, np.pi, (40, cfg.n_features))
    angles[5] = np.nan
    s = StreamingLOFSegmenter(cfg, fps=100.0)
    s.learn_many(angles)
    s.learn_one(angles[0])
    s._rebuild_derived()  # a restored checkpoint's neighbour lists
    s.finish()
    # the confirming contrast, whether or not the random stream had a candidate
    fb = np.empty(angles.shape, dtype=np.int8)
    valid = np.empty(angles.shape[0], dtype=np.uint8)
    bin_frames(angles, cfg.bins, fb, valid)
    scratch = np.zeros(fb.shape[1] * cfg.bins, dtype=np.int64)
    contrast_at(fb, valid, fb.shape[0], 20, 10, cfg.bins, fb.shape[0], 0, scratch, scratch.copy())
