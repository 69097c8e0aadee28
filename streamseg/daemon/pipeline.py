"""The per-stream algorithm side of the daemon (the daemon itself only moves bytes).

For each packet of joint positions ``(n, J, 3)`` a :class:`StreamPipeline` computes the 8 bone
angles and, by default, the 9 bone inclinations from the stream's up axis
(:func:`streamseg.skeleton.bone_angles`), feeds them in one call to the streaming LOF
segmenter (``learn_many``), and keeps the last H seconds of features in a ring buffer that a
worker thread relabels with windowed ACA (:func:`streamseg.daemon.relabel_job.relabel`).

The segmenter sees every stream frame (non-finite ones it skips itself), so its cuts are in
stream frames; the ring keeps only finite feature rows with their stream frame numbers.

Repetition counting (:class:`streamseg.online.RepetitionCounter`, off by default) runs in
:meth:`StreamPipeline.push` on the positions. What each stream runs comes from
:class:`streamseg.daemon.algorithms.Algorithms`.
"""

from __future__ import annotations

import collections
import math

import numpy as np

from streamseg.daemon.cut_events import cut_kind
from streamseg.daemon.relabel_job import segment_triplets
from streamseg.online.rep_bridge import BRIDGE_S
from streamseg.recording import Skeleton
from streamseg.state import Stateful

__all__ = ["StreamPipeline"]


RECENT_CUTS = 256  # live cuts a stream keeps for its relabels
RING_START = 256  # rows of the feature ring at first (it doubles up to the history)
RESTART_GAP_S = 10.0  # lost frames up to this long go through the gap filler; longer: restart
UP_CHECK_S = 2.0  # seconds of frames the declared up axis is checked on


def _finite(x):
    """``x`` as a float, None when absent or not finite (events are strict JSON)."""
    return None if x is None or not math.isfinite(x) else float(x)


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
    algorithms : streamseg.daemon.algorithms.Algorithms
        Shared algorithm factory.
    history : float
        Seconds of features kept for relabelling (the ring's size).
    """

    STATE_VERSION = 3  # 2: root speeds, settlement; 3: marker_fill
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
        "marker_fill",
    )

    # ``algorithms`` is not annotated: its module builds pipelines (the warm-up), so importing
    # it here would close an import circle
    def __init__(self, skeleton: Skeleton, fps: float, algorithms, history: float):
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
        # a marker map's lost markers placed from their segments (the state of a
        # LiveMarkerFill; None: no map, or no clusters or pairs among the stream's markers)
        self.marker_fill = None

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
        ``kind`` one of :data:`~streamseg.daemon.cut_events.CUT_KINDS`; :attr:`cut_frames`
        keeps the cuts not withdrawn."""
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
            New cut events, in stream frames (``kind``:
            :data:`~streamseg.daemon.cut_events.CUT_KINDS`).
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

            if self.plan[4] is not None:
                positions = self._place_lost_markers(positions)
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

    def _place_lost_markers(self, positions: np.ndarray) -> np.ndarray:
        """Markers of the map lost in ``positions`` placed from the others of their segment
        (:class:`streamseg.skeleton.marker_fill.LiveMarkerFill`, as the offline readers do,
        from the past only); the first placement of each marker is a ``markers`` notice."""
        from streamseg.skeleton.marker_fill import LiveMarkerFill

        fill = LiveMarkerFill(self.plan[4], self.marker_fill)
        positions, notes = fill.fill(positions)
        self.marker_fill = fill.state
        self.notices += [("markers", n) for n in notes]
        return positions

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
        segs = segment_triplets(w) if w is not None else []
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

    def release(self) -> None:
        """The take ended and its final relabel's snapshot is taken: free what only new
        frames need (the detector, the counter, the gap filler, the feature ring). What
        settles its cuts and names its labels stays (:meth:`relabelled`)."""
        self.segmenter = self.reps = self.root = self.filler = None
        self._feat = None
        self._frames = np.zeros(0, dtype=np.int64)

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
