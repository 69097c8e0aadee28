"""The per-stream algorithm side of the daemon (the daemon itself only moves bytes).

For each packet of joint positions ``(n, J, 3)`` a :class:`StreamPipeline` computes the 8 bone
angles and, by default, the 9 bone inclinations from the stream's up axis
(:func:`streamseg.skeleton.bone_angles`), feeds them in one call to the streaming LOF
segmenter (``learn_many``), and keeps the last H seconds of features in a ring buffer that a
worker thread relabels with windowed ACA (:func:`streamseg.offline.relabel_window`).

The segmenter sees every stream frame (non-finite ones it skips itself), so its cuts are in
stream frames; the ring keeps only finite feature rows with their stream frame numbers.

Repetition counting (:class:`streamseg.online.RepetitionCounter`, off by default) runs in
:meth:`StreamPipeline.push` on the positions.
"""

from __future__ import annotations

import collections
import math
import time
from dataclasses import dataclass

import numpy as np

from streamseg.daemon.alternation import merge_alternations
from streamseg.offline.identity import snap_to_cuts, stable_labels
from streamseg.online.events import ConfirmEvent, WithdrawEvent
from streamseg.online.rep_bridge import BRIDGE_S
from streamseg.recording import Skeleton
from streamseg.state import Stateful

__all__ = ["Algorithms", "Relabelled", "StreamPipeline", "relabel", "stable_labels"]


@dataclass(frozen=True)
class Relabelled:
    """A relabel mapped to stream frames: ``segments`` are ``(start, end, label)``."""

    start: int
    end: int
    segments: tuple
    window: object  # the same as a WindowSegmentation in stream frames (the next ``previous``)
    elapsed: float


class Algorithms:
    """The algorithms one daemon runs, with their configurations.

    Parameters
    ----------
    lof_config : LOFConfig or None
        Streaming cut detector configuration (None: the library default).
    aca_config : ACAConfig or None
        Windowed relabelling configuration (None: the library default).
    relabel : callable or None
        Replaces :func:`streamseg.offline.relabel_window` (same signature); tests use it to
        make a relabel slow.
    memory_config : LabelMemoryConfig or None
        The exemplar memory that keeps ids beyond the relabel history
        (:mod:`streamseg.offline.label_memory`); None: off (ids carried by overlap only).
    gap_fill_s : float or None
        Longest gap filled by interpolation, seconds (None: the daemon's
        ``DaemonConfig.gap_fill``; outside a daemon :data:`streamseg.io.gaps.FILL_S`).
    settle_s : float or None
        Seconds of frames a relabel needs after a provisional cut to settle it (confirm or
        withdraw it, :mod:`streamseg.daemon.settle`); 0: cuts are not settled and make no
        relabel due. None: the daemon's ``DaemonConfig.settle``, outside a daemon
        :data:`SETTLE_S`.
    focus_s : float or None
        Seconds before the oldest open cut the window of the relabel it makes due starts
        (None: ``DaemonConfig.focus`` in a daemon, else :data:`FOCUS_S`).
    radius_s : float or None
        A relabel boundary within this many seconds of a provisional cut confirms it (None:
        :data:`RADIUS_S`).
    alternations : bool
        Merge a revision's alternations of two labels into one action before it is published
        (:mod:`streamseg.daemon.alternation`; False: HACA's labels as they are).
    markers : MarkerSet or None
        A marker map of the user's own (:func:`streamseg.skeleton.marker_map.load_marker_map`,
        ``--markers MAP.toml``): a stream whose announced joints hold its markers is
        segmented on the joints it makes; other streams as announced.
    """

    def __init__(
        self,
        lof_config=None,
        aca_config=None,
        relabel=None,
        repetitions=False,
        rep_config=None,
        memory_config=None,
        gap_fill_s=None,
        settle_s=None,
        focus_s=None,
        radius_s=None,
        markers=None,
        alternations=True,
    ):
        self.lof_config = lof_config
        self.aca_config = aca_config
        self._relabel = relabel
        self.repetitions = repetitions
        self.rep_config = rep_config
        self.memory_config = memory_config
        self.gap_fill_s = None if gap_fill_s is None else float(gap_fill_s)
        self.settle_s = None if settle_s is None else float(settle_s)
        self.focus_s = None if focus_s is None else float(focus_s)
        self.radius_s = None if radius_s is None else float(radius_s)
        self.markers = markers
        self.alternations = bool(alternations)

    def settlement(self, fps: float):
        """A stream's :class:`~streamseg.daemon.settle.Settlement` (None: settling off)."""
        from streamseg.daemon.settle import Settlement

        settle = SETTLE_S if self.settle_s is None else self.settle_s
        if settle <= 0:
            return None
        focus = FOCUS_S if self.focus_s is None else self.focus_s
        radius = int(round((RADIUS_S if self.radius_s is None else self.radius_s) * fps))
        return Settlement(fps, settle, focus, radius)

    def prepare(self, skeleton: Skeleton):
        """Per-stream feature plan: bone end-point indices, resolved once (raises
        SkeletonError when the skeleton lacks a joint the 8 angles need), the skeleton's
        up vector when the cut detector uses inclinations (else None), both as the
        arguments of the angle kernel (:meth:`StreamingLOFSegmenter.learn_positions`), and
        the marker map's columns when it applies (:meth:`joints_of`; else None)."""
        from streamseg.config import LOFConfig
        from streamseg.skeleton.bones import bone_point_indices, up_vector

        skeleton, columns = self.joints_of(skeleton)
        inclinations = (self.lof_config or LOFConfig()).inclinations
        points = bone_point_indices(skeleton)
        up = up_vector(skeleton.up) if inclinations else None
        return points, up, _bone_args(points, up), columns

    def joints_of(self, skeleton: Skeleton):
        """``(skeleton, columns)``: the skeleton a stream's features are computed on and the
        marker map's columns for it (:func:`streamseg.skeleton.marker_map.marker_columns`),
        when ``markers`` is set and the announced joints hold its markers; else the
        announced skeleton and None. Raises SkeletonError when the announced joints are
        neither the map's markers nor a skeleton streamseg knows."""
        if self.markers is None:
            return skeleton, None
        from streamseg.skeleton.marker_map import columns_for
        from streamseg.skeleton.marker_sets import JOINTS, PARENTS

        columns = columns_for(self.markers, skeleton.names)
        if columns is None:
            return skeleton, None
        return Skeleton(
            JOINTS, np.array(PARENTS), np.zeros((len(JOINTS), 3)), skeleton.units, skeleton.up
        ), columns

    def angles(self, positions: np.ndarray, plan) -> np.ndarray:
        """Features ``(n, d)`` of positions ``(n, J, 3)`` (the 8 bone angles, then the 9
        inclinations when the plan has an up vector): :func:`streamseg.skeleton.bones.
        angles_at` with the joint names resolved once per stream in :meth:`prepare` (that
        lookup costs more than the maths for a packet of a few frames)."""
        from streamseg.skeleton.bones import angles_at

        return angles_at(positions, plan[0], plan[1])

    def segmenter(self, fps: float):
        """A fresh streaming cut detector for one stream."""
        from streamseg.config import LOFConfig
        from streamseg.online.lof import StreamingLOFSegmenter

        return StreamingLOFSegmenter(self.lof_config or LOFConfig(), fps)

    def relabel(self, features: np.ndarray, start_frame: int, fps: float):
        """Windowed ACA of ``features`` (m, d); row 0 is learned frame ``start_frame``.

        Cluster ids are the window's own; :func:`relabel` maps the rows to stream frames and
        then makes the ids consistent with the previous relabel (:func:`stable_labels`),
        because rows and stream frames differ wherever frames were missing.
        """
        from streamseg.offline import relabel_window

        fn = self._relabel or relabel_window
        return fn(
            features, start_frame=start_frame, fps=fps, config=self.relabel_config, previous=None
        )

    @property
    def relabel_config(self):
        """The ACA configuration relabelling uses."""
        from streamseg.config import ACAConfig

        return self.aca_config or ACAConfig()

    def root_speed(self, fps: float, skeleton: Skeleton):
        """The stream's root-speed columns (:class:`streamseg.online.root_speed.RootSpeed`),
        or None when the cut detector has none (``LOFConfig.root_speed_max = 0``)."""
        from streamseg.config import LOFConfig

        config = self.lof_config or LOFConfig()
        if not config.root_columns:
            return None
        from streamseg.online.root_speed import RootSpeed

        return RootSpeed(config, fps, skeleton)

    def rep_counter(self, fps: float, skeleton: Skeleton):
        """A live repetition counter for one stream, or None when turned off."""
        if not self.repetitions:
            return None
        from streamseg.online.repetition import RepetitionCounter

        return RepetitionCounter(self.rep_config, fps, skeleton)

    def warmup(self, relabel: bool = True) -> float:
        """Compile and run every kernel once on synthetic data; returns seconds spent."""
        from streamseg.offline.relabel import warmup as warmup_aca
        from streamseg.online.lof import warmup as warmup_lof
        from streamseg.skeleton.bones import angles_at

        t = time.perf_counter()
        warmup_lof()
        if relabel:
            warmup_aca()
        if self.repetitions:
            from streamseg.online.repetition import warmup as warmup_reps

            warmup_reps()
        plan = np.arange(18).reshape(9, 2) % 9
        angles_at(np.zeros((2, 9, 3)), plan)
        angles_at(np.zeros((2, 9, 3)), plan, np.array([0.0, 1.0, 0.0]))
        from streamseg._kernels import root_speed as _kr

        _kr.root_speeds(
            np.ones((2, 9, 3)),
            0,
            plan[1:].astype(np.int64),
            np.array([0.0, 1.0, 0.0]),
            np.array([0, 1]),
            np.zeros((3, 3)),
            np.zeros(3),
            1.0,
            1.0,
            1.0,
            np.empty((2, 2)),
        )
        rng = np.random.default_rng(0)
        # a random walk of angles: enough frames for the LOF windows to fill and cut
        fps = 120.0
        seg = self.segmenter(fps)
        walk = np.clip(
            1.5 + np.cumsum(rng.normal(0, 0.01, (6 * int(fps), seg.n_features)), axis=0), 0, 3
        )
        seg.learn_many(walk)
        seg.finish()
        if relabel:
            # the relabels read the bone features, not the root speeds
            self.relabel(walk[-int(4 * fps) :, : seg.n_features - seg.config.root_columns], 0, fps)
        self._warm_stream(fps, rng)
        return time.perf_counter() - t

    def _warm_stream(self, fps: float, rng) -> None:
        """A stream's own path (gap filler, one kernel call per packet, the counter) on a
        random walk of a Kinect v2 body, so its first packets compile nothing in the loop."""
        from streamseg.daemon.options import skeleton_from
        from streamseg.skeleton.joint_sets import KINECT_V2

        n = len(KINECT_V2.names)
        # as an announce of these joints makes it
        skeleton = skeleton_from(KINECT_V2.names, [-1] * n, KINECT_V2.units, KINECT_V2.up)
        pipe = StreamPipeline(skeleton, fps, self, history=4.0)
        base = rng.normal(0, 0.3, (1, n, 3)) + np.array([0.0, 1.0, 0.0])
        walk = base + np.cumsum(rng.normal(0, 0.002, (3 * int(fps), n, 3)), axis=0)
        walk[10, 3] = np.nan  # a filled gap
        half = walk.shape[0] // 2
        pipe.push(walk[:half], 0)
        pipe.push(walk[half:], half)
        pipe.finish()
        pipe.finish_reps()


def algorithms_for(config, algorithms: Algorithms | None = None) -> Algorithms:
    """The daemon's per-stream algorithms: ``algorithms`` (default: LOF cuts + ACA relabel
    with default configs) with what it leaves unset taken from ``config``. What
    ``Algorithms(...)`` was given wins over the config."""
    algorithms = algorithms or Algorithms(repetitions=config.repetitions)
    if config.label_memory and algorithms.memory_config is None:
        from streamseg.config.memory import LabelMemoryConfig

        # the switch turns the memory on with its defaults; Algorithms(memory_config=...)
        # sets other ones (and turns it on by itself)
        algorithms.memory_config = LabelMemoryConfig()
    if algorithms.gap_fill_s is None:
        algorithms.gap_fill_s = float(config.gap_fill)
    if algorithms.settle_s is None:  # settling needs relabels
        algorithms.settle_s = float(config.settle) if config.relabel_interval > 0 else 0.0
    if algorithms.focus_s is None:
        algorithms.focus_s = float(config.focus)
    if algorithms.markers is None and config.markers:
        from streamseg.skeleton.marker_map import load_marker_map

        algorithms.markers = load_marker_map(config.markers)
    return algorithms


def _bone_args(points: np.ndarray, up) -> tuple:
    """The angle kernel's arguments (:func:`streamseg._kernels.bones.angles_kernel`) for bone
    end points ``points`` (9, 2) and the up vector (None: no inclinations), as
    :func:`streamseg.skeleton.bones.angles_at` passes them."""
    from streamseg.skeleton.bones import ANGLES, INCLINATIONS

    pairs = np.array(ANGLES + (INCLINATIONS if up is not None else ()), dtype=np.int64)
    return (
        np.ascontiguousarray(points[:, 0], dtype=np.int64),
        np.ascontiguousarray(points[:, 1], dtype=np.int64),
        np.ascontiguousarray(pairs[:, 0]),
        np.ascontiguousarray(pairs[:, 1]),
        np.zeros(3) if up is None else np.asarray(up, dtype=np.float64),
    )


def _segment_triplets(window) -> list:
    """``(start, end, label)`` of the algorithm's segments (objects or tuples)."""
    out = []
    for s in window.segments:
        if hasattr(s, "start"):
            out.append((int(s.start), int(s.end), int(s.label)))
        else:
            out.append((int(s[0]), int(s[1]), int(s[2])))
    return out


RECENT_CUTS = 256  # live cuts a stream keeps for its relabels
SETTLE_S = 8.0  # seconds of frames after a provisional cut a relabel needs to settle it
FOCUS_S = 20.0  # seconds before the oldest open cut a focused relabel's window starts
RADIUS_S = 1.0  # a relabel boundary this close to a provisional cut confirms it
RING_START = 256  # rows of the feature ring at first (it doubles up to the history)
RESTART_GAP_S = 10.0  # lost frames up to this long go through the gap filler; longer: restart
UP_CHECK_S = 2.0  # seconds of frames the declared up axis is checked on
#: kinds of the cut events a pipeline step returns: a cut final when emitted, a pending cut
#: (two-stage detector), its confirmation, its withdrawal, its withdrawal before a cut nearby
CUT_KINDS = ("cut", "pending", "confirm", "withdraw", "moved")


def _finite(x):
    """``x`` as a float, None when absent or not finite (events are strict JSON)."""
    return None if x is None or not math.isfinite(x) else float(x)


def cut_kind(ev) -> str:
    """The :data:`CUT_KINDS` entry of a cut detector event."""
    if isinstance(ev, ConfirmEvent):
        return "confirm"
    if isinstance(ev, WithdrawEvent):
        return "moved" if ev.moved else "withdraw"
    return "pending" if ev.pending else "cut"


class StreamPipeline(Stateful):
    """One stream's algorithm state: segmenter, feature ring, frame clock.

    The segmenter sees stream frames one for one, after the gap filler
    (:class:`streamseg.io.gaps.GapFiller`, the mechanism ``streamseg segment`` applies to a
    file): short gaps of a joint are interpolated, a frame still without the features'
    positions is fed as is (the segmenter skips it but its clock advances), and lost frames
    of up to :data:`RESTART_GAP_S` seconds are frames without positions, so cut frames are
    stream frames and match an offline run of the file. A longer loss restarts the segmenter
    at the frame after it.

    Parameters
    ----------
    skeleton : Skeleton
        The stream's joints (names select the bones of the angles).
    fps : float
        Frame rate.
    algorithms : Algorithms
        Shared algorithm factory.
    history : float
        Seconds of features kept for relabelling (the ring's size).
    """

    STATE_VERSION = 2  # 2: root speeds, settlement
    _transient = ("algorithms", "plan")  # shared by the daemon's streams: given back at restore
    __slots__ = (
        "skeleton",
        "plan",
        "fps",
        "algorithms",
        "segmenter",
        "root",
        "reps",
        "_feat",
        "_frames",
        "learned",
        "previous",
        "offset",
        "next_frame",
        "_width",
        "rep_offset",
        "notices",
        "_spine",
        "_spine_n",
        "cut_frames",
        "_cap",
        "filler",
        "gaps",
        "final_bad",
        "final_reps",
        "settlement",
    )

    def __init__(self, skeleton: Skeleton, fps: float, algorithms: Algorithms, history: float):
        self.skeleton = skeleton  # as announced (its joints are the packets')
        self.plan = algorithms.prepare(skeleton)
        # the joints the features see: a marker map's (plan[3]: its columns), else these
        skeleton = algorithms.joints_of(skeleton)[0]
        self.fps = float(fps)
        self.algorithms = algorithms
        self.segmenter = algorithms.segmenter(fps)
        # the root speeds go to the cut detector only, not into the relabels' feature ring
        self.root = algorithms.root_speed(fps, skeleton)
        self.reps = algorithms.rep_counter(fps, skeleton)
        self.rep_offset = None  # stream frame of the counter's frame 0
        self.notices = []  # (reason, message) for the daemon to report, see push()
        # the live cuts a relabel snaps its boundaries to (the history holds fewer)
        self.cut_frames = collections.deque(maxlen=RECENT_CUTS)
        # the declared up axis is checked once, on the first UP_CHECK_S seconds of frames
        self._spine = np.zeros(3)
        self._spine_n = 0 if self.plan[1] is not None else -1  # -1: checked (or no need)
        cap = max(int(round(history * fps)), 2)
        self._cap = cap
        # the ring grows (doubling) up to ``cap`` rows as frames come: an idle or short
        # stream does not hold the whole history's memory (547 kB at 60 s x 120 Hz)
        self._feat = None  # allocated on the first packet, when the feature width is known
        self._frames = np.zeros(min(cap, RING_START), dtype=np.int64)
        self._width = self.segmenter.n_features - self.segmenter.config.root_columns
        self.learned = 0  # finite feature rows stored so far
        self.previous = None  # the last relabel result (algorithm's own object)
        self.offset = 0  # stream frame of the segmenter's frame 0
        self.next_frame = 0  # stream frame expected next
        from streamseg.io.gaps import FILL_S, GapFiller, fill_frames

        fill_s = FILL_S if algorithms.gap_fill_s is None else algorithms.gap_fill_s
        # the joints of the bone features decide what a gap is; every joint is filled
        self.filler = GapFiller(
            skeleton.n_joints, fill_frames(fps, fill_s), watch=np.unique(self.plan[0])
        )
        self.gaps = []  # (start, end) of gaps closed and not yet reported
        self.final_bad = 0  # frames skipped among those released at finish()
        self.final_reps = []  # repetitions completed by the frames released at finish()
        # the provisional cuts the relabels settle, and the relabel they make due
        self.settlement = algorithms.settlement(self.fps)

    @property
    def fill_frames(self) -> int:
        """The longest gap filled by interpolation, in frames."""
        return self.filler.max_frames

    @property
    def capacity(self) -> int:
        return self._cap

    @property
    def fill(self) -> float:
        """Fraction of the feature ring in use."""
        return min(self.learned, self.capacity) / self.capacity

    def _cuts(self, events) -> list:
        """The detector's events as ``(frame, score, emitted_at, kind)`` in stream frames,
        ``kind`` one of :data:`CUT_KINDS`; :attr:`cut_frames` keeps the cuts not withdrawn."""
        o, out = self.offset, []
        settle = self.settlement
        for ev in events:
            kind = cut_kind(ev)
            score = float(getattr(ev, "score", 0.0))
            out.append((ev.frame + o, score, ev.emitted_at + o, kind))
            if kind in ("cut", "pending"):
                self.cut_frames.append(ev.frame + o)
                if settle is not None:
                    settle.add(ev.frame + o, score, ev.emitted_at + o)
            elif kind in ("withdraw", "moved"):
                if ev.frame + o in self.cut_frames:
                    self.cut_frames.remove(ev.frame + o)
                if settle is not None:
                    settle.drop(ev.frame + o)
        return out

    def start_at(self, frame: int) -> None:
        """Before the first :meth:`push`: the take's first frame is ``frame`` (a take joined
        late, through a subscription), not 0."""
        self.next_frame = self.offset = frame

    def push(self, positions: np.ndarray, first_frame: int):
        """Learn stream frames ``first_frame ...`` of ``positions`` (n, J, 3).

        Frames first go through the stream's gap filler (:mod:`streamseg.io.gaps`, as a file
        of the take would): a joint's gap of at most ``fill_frames`` frames, lost frames
        included, is filled by interpolation once it closes (its frames wait until then);
        frames of longer gaps are skipped by the detectors and listed in :attr:`gaps`.

        Returns
        -------
        cuts : list of (frame, score, emitted_at, kind)
            New cut events, in stream frames (``kind``: :data:`CUT_KINDS`).
        reps : list of (start, end, count, emitted_at, label, set_index, duration_s, rom_deg,
                rom_joint, likeness)
            Completed repetitions (empty without a repetition counter): ``count`` in its
            set, the action ``label`` (None: not yet relabelled;
            :mod:`streamseg.online.rep_sets`), the set's index (the counter's) and the
            repetition's measures (:class:`streamseg.online.RepEvent`).
        n_bad : int
            Frames received whose features are not finite after the gap filling (skipped by
            the segmenter and the ring).

        Problems that do not stop the stream (the repetition counter failed, the up axis
        looks wrong) are appended to ``notices`` as ``(reason, message)``; the caller reports
        and clears them.
        """
        out, reps, n_bad = [], [], 0
        if self.plan[3] is not None:  # markers: the joints of the map
            from streamseg.skeleton.marker_map import joints_of_markers

            positions = joints_of_markers(positions, self.plan[3])
        gap = first_frame - self.next_frame
        lost = None
        if 0 < gap <= RESTART_GAP_S * self.fps:  # lost frames: frames without positions
            positions = np.concatenate([np.full((gap,) + positions.shape[1:], np.nan), positions])
            lost = np.zeros(positions.shape[0], dtype=bool)
            lost[:gap] = True
            first_frame = self.next_frame
        elif gap > 0:  # a long absence: the detector starts anew at first_frame
            out, reps, n_bad = self._learn(*self.filler.finish(), self.filler.released_lost)
            out += self._cuts(self.segmenter.finish())
            self.segmenter = self.algorithms.segmenter(self.fps)
            self.offset = first_frame
            if self.root is not None:  # a new detector: a stream's first frame
                self.root.reset()
        self.next_frame = first_frame + positions.shape[0]
        released, start = self.filler.push(
            positions, first_frame if not self.filler.held else None, lost
        )
        c, r, b = self._learn(released, start, self.filler.released_lost)
        self._take_gaps()
        return out + c, reps + r, n_bad + b

    def _learn(self, positions: np.ndarray, first_frame: int, lost=None):
        """:meth:`push` on frames the gap filler released (contiguous from ``first_frame``)."""
        n = positions.shape[0]
        if n == 0:
            return [], [], 0
        # features, root speeds, speeds and the detector in one kernel call
        angles, ok, events = self.segmenter.learn_positions(positions, self.plan[2], self.root)
        if self._spine_n >= 0:
            self._check_up(positions)
        self._width = angles.shape[1]
        out = self._cuts(events) if events else []
        n_good = int(np.count_nonzero(ok))
        n_bad = n - n_good
        if n_bad and lost is not None:  # frames that never came are counted as lost
            n_bad -= int(np.count_nonzero(~ok & lost))
        if n_good == 0:
            self._remember(angles[:0], first_frame)
        elif n_good < n:
            self._remember(angles[ok], first_frame + np.flatnonzero(ok))
        else:
            self._remember(angles, first_frame)
        reps = self._repetitions(positions, first_frame) if self.reps is not None else []
        return out, reps, n_bad

    def _take_gaps(self) -> None:
        """Gaps the filler closed that hold frames which came without positions (gaps of lost
        frames only are reported where the loss is seen)."""
        if self.filler.gaps:
            self.gaps += [(s, e) for s, e, all_lost in self.filler.take_gaps() if not all_lost]

    def _check_up(self, positions: np.ndarray) -> None:
        """Add an ``up`` notice (once) when the body stands along another axis than the
        declared up: the inclinations would then change with heading."""
        from streamseg.skeleton.bones import likely_up, spine_directions

        s, n = spine_directions(positions, self.plan[0])
        self._spine += s
        self._spine_n += n
        if self._spine_n < UP_CHECK_S * self.fps:
            return
        axis = likely_up(self._spine, self.skeleton.up)
        if axis is not None:
            self.notices.append(
                (
                    "up",
                    f"over the first {UP_CHECK_S:g} s the spine points along {axis}, not along the "
                    f"announced up axis {self.skeleton.up}: announce up = {axis!r} (streamseg "
                    "replay --up), or the bone inclinations change with the heading",
                )
            )
        self._spine_n = -1

    def _repetitions(self, positions, first_frame) -> list:
        """Completed repetitions as :meth:`push` gives them, in stream frames.

        The counter sees every frame the gap filler releases, joints still lost included:
        it bridges them itself as offline (:mod:`streamseg.online.rep_bridge`), so a marker
        lost for good stops nothing and its frame numbers are the stream's offset by the
        first one (exact unless the stream restarted after a long absence).
        """
        if self.rep_offset is None:
            self.rep_offset = first_frame
        try:
            reps = self.reps.learn_many(positions)
        except Exception as err:  # the counter is optional: turn it off for this stream
            self.reps = None
            self.notices.append(
                ("rep", f"repetition counting stopped: {type(err).__name__}: {err}")
            )
            return []
        lost = self.reps.new_lost_joints()
        if lost:
            self.notices.append(
                (
                    "rep",
                    f"{', '.join(lost)} lost for more than "
                    f"{BRIDGE_S:g} s: repetitions counted with the other "
                    "body parts (held where last seen)",
                )
            )
        return self._rep_tuples(reps)

    def finish_reps(self) -> list:
        """The repetitions the counter still holds at the stream's end (its ``finish``), as
        :meth:`push` gives them."""
        flushed, self.final_reps = self.final_reps, []
        if self.reps is None or self.rep_offset is None:
            return flushed
        return flushed + self._rep_tuples(self.reps.finish())

    def _rep_tuples(self, reps) -> list:
        from streamseg.online.rep_sets import label_at

        o = self.rep_offset
        w = self.previous
        segs = _segment_triplets(w) if w is not None else []
        out = []
        for r in reps:
            a, b = r.start + o, r.end + o
            label = label_at(a, b, segs, getattr(w, "end", None), self.cut_frames)
            out.append(
                (
                    a,
                    b,
                    int(r.count),
                    r.emitted_at + o,
                    label,
                    int(r.set_index),
                    r.duration_s,
                    _finite(r.rom_deg),
                    r.rom_joint,
                    _finite(r.likeness),
                )
            )
        return out

    def finish(self) -> list:
        """Cuts the segmenter still holds at the end of the stream, in stream frames.

        A stream that ended before its first complete detector window adds a ``short``
        notice: it could not have had a cut, which a listener should not read as "no change".
        """
        cuts, reps, self.final_bad = self._learn(*self.filler.finish(), self.filler.released_lost)
        self._take_gaps()
        self.final_reps = reps
        seen = self.segmenter.n_frames_
        window = self.segmenter.geometry["window"]
        if self.offset == 0 and seen < window:
            self.notices.append(
                (
                    "short",
                    f"the stream ended after {seen} frames ({seen / self.fps:.2f} s), shorter than "
                    f"the cut detector's window of {window} frames ({window / self.fps:.2f} s): no "
                    "cut could be found",
                )
            )
        return cuts + self._cuts(self.segmenter.finish())

    def _remember(self, angles: np.ndarray, frames) -> None:
        """Append feature rows to the ring; ``frames``: their stream frames (int64 array),
        or an int, the first of consecutive frames."""
        cap = self.capacity
        if self._feat is None:
            # float32 halves the per-stream memory; ACA gets float64 copies
            self._feat = np.zeros((self._frames.shape[0], angles.shape[1]), dtype=np.float32)
        m = angles.shape[0]
        size = self._frames.shape[0]
        if size < cap and self.learned + m > size:  # not wrapped yet: rows 0..learned-1
            grown = min(cap, max(2 * size, self.learned + m))
            feat = np.zeros((grown, self._feat.shape[1]), dtype=np.float32)
            fr = np.zeros(grown, dtype=np.int64)
            feat[: self.learned], fr[: self.learned] = (
                self._feat[: self.learned],
                self._frames[: self.learned],
            )
            self._feat, self._frames = feat, fr
        first = self.learned
        if isinstance(frames, (int, np.integer)):
            frames = frames + np.arange(m, dtype=np.int64)
        if m > cap:  # only the newest ``cap`` rows fit
            angles, frames = angles[-cap:], frames[-cap:]
            first += m - cap
        # at most two contiguous runs of the ring: slices, not an index array
        a = first % cap
        k = min(angles.shape[0], cap - a)
        self._feat[a : a + k] = angles[:k]
        self._frames[a : a + k] = frames[:k]
        if k < angles.shape[0]:
            self._feat[: angles.shape[0] - k] = angles[k:]
            self._frames[: angles.shape[0] - k] = frames[k:]
        self.learned += m

    def relabel_due(self, next_relabel: int) -> bool:
        """Whether this stream should be relabelled now: ``next_relabel`` stored rows are in
        (the daemon's cadence, ``relabel_interval``), or a provisional cut waits to be
        settled (:mod:`streamseg.daemon.settle`)."""
        if self.learned >= next_relabel:
            return True
        settle = self.settlement
        return settle is not None and settle.due(self.next_frame)

    def relabel_snapshot(self, whole: bool):
        """The features of the next relabel job: the whole history (``whole``: the cadence's
        relabel, or the final one), else the window of the relabel the open provisional
        cuts made due (from ``focus_s`` before the oldest of them).

        Returns
        -------
        features, frames : as :meth:`snapshot`
        focused : bool
            True when the window is the focused one (the cadence is left as it was).
        """
        settle = self.settlement
        focused = not whole and settle is not None and bool(settle.open)
        feats, frames = self.snapshot(first_frame=settle.window_start() if focused else None)
        if settle is not None:
            settle.taken()
        return feats, frames, focused

    def relabelled(self, result, final: bool, now: int, focused: bool = False) -> list:
        """Take a relabel's result (``Relabelled``, or None when it failed) as the next
        ``previous`` and settle the provisional cuts it holds, at stream frame ``now``.

        The result of a ``focused`` job (a window a cut made due, :meth:`relabel_snapshot`)
        settles cuts but is not the next ``previous``: the cadence's revisions carry the ids
        and the label memory from one to the next as without settling.

        Returns
        -------
        list of (frame, score, emitted_at, kind, settled)
            ``kind`` ``"confirmed"`` (at the relabel's frame ``settled``), ``"rejected"``
            (withdrawn) or ``"found"`` (a boundary no cut announced, announced as a cut that is
            not provisional); empty with settling off.
        """
        if result is not None and not focused:
            self.previous = result.window
        settle = self.settlement
        if settle is None:
            return []
        if result is None:  # a failed relabel settles nothing, but the final one must end
            if not final:
                return []
            segs, start, end = (), now, now  # every open cut stands
        else:
            segs, start, end = result.segments, result.start, result.end
        # later relabels snap to every cut the detector made, settled or not, as without
        # settling: a withdrawn true cut still draws a boundary the relabel finds near it
        out = settle.apply(segs, start, end, final, now, self.offset)
        return out

    def snapshot(self, seconds: float | None = None, first_frame: int | None = None):
        """Copy of the last ``seconds`` of stored features for a relabel job (from stream
        frame ``first_frame`` on, when given).

        Returns
        -------
        features : ndarray of float64, shape (m, d)
        frames : ndarray of int64, shape (m,)
            Stream frame number of each row (increasing; consecutive without drops).
        """
        cap = self.capacity
        m = min(self.learned, cap)
        if seconds is not None:
            m = min(m, int(round(seconds * self.fps)))
        if m and first_frame is not None and self._feat is not None:
            frames = self._frames[(self.learned - m + np.arange(m)) % cap]
            m -= int(np.searchsorted(frames, first_frame))
        if m == 0 or self._feat is None:
            return np.zeros((0, self._width)), np.zeros(0, dtype=np.int64)
        idx = (self.learned - m + np.arange(m)) % cap
        return self._feat[idx].astype(np.float64), self._frames[idx].copy()


def relabel(algorithms: Algorithms, features, frames, fps, previous, cuts=()) -> Relabelled:
    """Run one relabel job in stream frames (runs in the worker).

    The algorithm sees ``start_frame = frames[0]`` and contiguous rows; a segment bound ``b``
    is row ``b - frames[0]``, mapped back through ``frames`` (the identity without dropped
    frames). Boundaries between actions then move to a live cut (``cuts``, stream frames)
    within the shortest segment length, ``min_len`` (:func:`snap_to_cuts`), and ids are made
    stream-wide (:func:`stable_labels`: the overlap with ``previous``; never a reused id;
    with ``algorithms.memory_config``, also the exemplars of ids the window no longer holds,
    clustered with it: :mod:`streamseg.offline.label_memory`).
    """
    from dataclasses import replace

    from streamseg.offline.label_memory import new_memory
    from streamseg.offline.recall import recall
    from streamseg.offline.relabel import WindowSegmentation

    t = time.perf_counter()
    start = int(frames[0])
    mcfg = algorithms.memory_config
    window = algorithms.relabel(features, start, fps)
    m = frames.shape[0]
    segs = []
    for a, b, label in _segment_triplets(window):
        a_i, b_i = a - start, b - start
        if b_i <= 0 or a_i >= m:
            continue
        a_i, b_i = max(a_i, 0), min(b_i, m)
        segs.append((int(frames[a_i]), int(frames[b_i - 1]) + 1, int(label)))
    radius = int(round(algorithms.relabel_config.min_len_s * fps))
    segs = snap_to_cuts(segs, [c for c in cuts if start < c < int(frames[-1])], radius)
    if algorithms.alternations:
        segs = merge_alternations(segs)
    k = int(getattr(window, "n_clusters", 0))
    stable = stable_labels(WindowSegmentation(start, int(frames[-1]) + 1, segs, k), previous)
    if mcfg is not None:
        memory = getattr(previous, "memory", None) or new_memory(mcfg, fps, start)
        stable, memory, _ = recall(stable, previous, memory, features, frames, mcfg, fps)
        memory = memory.updated(stable.segments, features, frames, mcfg, fps)
        stable = replace(stable, memory=memory)
    elapsed = time.perf_counter() - t
    return Relabelled(stable.start, stable.end, tuple(stable.segments), stable, elapsed)
