"""Repetition counting, live and offline alike: loops of the pose followed one by one.

How it works. Each frame becomes a heading-free pose vector (bone directions in the torso
frame, the trunk's direction, the pelvis height: :func:`streamseg._kernels.rep_track.
pose_features`), low-passed causally and decimated to about ``rate_hz``. A *loop* starts at
an anchor frame: the pose moves away from the anchor's (at least ``min_amplitude``) and comes
back (within ``return_ratio`` of the farthest distance); the loop is cut at the slowest frame
of its rest when the pose moves away again, or ``pause_s / 2`` into a rest of ``pause_s``.
Each loop's duration is its own: the period is followed cycle by cycle. A loop is compared
(duration, DTW shape) by its moving frames: a rest between repetitions (frames slower than
``still_ratio`` of the loop's peak speed) makes no loop longer or unlike the others.

Two modes. *Looking for a set*: an anchor at every speed minimum (the pose's turning and
resting points), so loops of any phase close; a set starts when two consecutive loops are
alike (their DTW distance is at most ``max_dissimilarity`` of their amplitude) and span the
pose range they cover (``spread_ratio``: not two sub-motions of a longer movement) and last
within ``start_tempo_ratio`` of each other. *In a set*: one anchor, the last cut; each closed
loop like the previous one is the next repetition. A set ends at a loop unlike the last
(another exercise: the search restarts at that loop, which may begin the next set), at a
rest of ``pause_s``, or when no loop closes within ``timeout_cycles`` median repetitions (at
most ``max_cycle_s``). A piece before the set's first loop or at the stream's end counts when
its DTW alignment with the neighbouring repetition passes the same test (``extend_edges``).

Events. A repetition is reported (:class:`RepEvent`) when its loop closes: as the next one
starts (within the rest's half plus about 0.2 s of its end), the first two of a set when the
second closes. ``RepetitionSegmenter`` (offline) runs this very counter over a whole
recording, so the live count of every set equals the offline one.

Where. The pose vector: :mod:`streamseg.online.rep_pose`; the ring of recent poses and how two
loops compare: :mod:`streamseg.online.rep_loops`; the input (lost joints bridged, pose rows):
:mod:`streamseg.online.rep_counter_input`; how a set starts, resumes and records its
repetitions: :mod:`streamseg.online.rep_set_records`; the end of a stream:
:mod:`streamseg.online.rep_stream_end`; here, the tracker and when a set starts and ends.
"""

from __future__ import annotations

import numpy as np

from streamseg._kernels import frames_in
from streamseg._kernels import rep_track as K
from streamseg.config import RepetitionConfig
from streamseg.exceptions import ParameterError
from streamseg.online.rep_counter_input import PoseInput
from streamseg.online.rep_events import RepEvent, RepSet, sets_of, stream_events
from streamseg.online.rep_loops import PoseRing
from streamseg.online.rep_set_records import SetRecords
from streamseg.online.rep_stream_end import StreamEnd
from streamseg.state import Stateful

__all__ = ["RepEvent", "RepSet", "RepetitionCounter", "sets_of", "stream_events"]


class RepetitionCounter(PoseInput, SetRecords, StreamEnd, Stateful):
    """Count repetitions in a joint-position stream (or a stream of pose features).

    Parameters
    ----------
    config : RepetitionConfig, optional
    fps : float
    skeleton : Skeleton or sequence of str, optional
        Joint names (and ``up``) of the incoming frames. None: :meth:`learn_many` takes pose
        feature rows (n, d) instead of positions.

    Attributes
    ----------
    n_seen_ : int
        Frames received.
    count_ : int
        Repetitions of the current set (0 between sets).
    sets_ : list of RepSet
        Every set so far (the current one last while under way).
    n_loops_ : int
        Loops closed (repetitions or not).
    best_dissimilarity_ : float
        Smallest dissimilarity of two consecutive loops seen (inf: none), for the reason a
        take has no set.
    near_misses_ : dict
        Pairs of consecutive loops alike in shape that did not start a set, by the test they
        failed (``"tempo"``, ``"span"``, ``"amplitude"``: :meth:`PoseRing.spread_fault`).
    max_excursion_ : float
        Farthest the pose went from any anchor.
    """

    STATE_VERSION = 6  # 2: near_misses_, _unliked; 3: _final always stored; 4: _bridge,
    # _waits; 5: _skip, _cur's moving lengths; 6: _lead

    def __init__(self, config: RepetitionConfig | None = None, fps: float = 120.0, skeleton=None):
        if not np.isscalar(fps) or not fps > 0:
            raise ParameterError(f"fps={fps!r} is invalid: expected the stream's frame rate > 0")
        self.config = cfg = config or RepetitionConfig()
        self.fps = float(fps)
        self._names = None if skeleton is None else tuple(getattr(skeleton, "names", skeleton))
        self._up = getattr(skeleton, "up", "y")
        self._ring = PoseRing(cfg, self.fps)
        rate = self.fps / self._ring.dec
        delay = np.sqrt(2.0) / (2 * np.pi * self._ring.cutoff)  # the filter's delay at low rates
        self._lag = int(round(delay * self.fps)) if cfg.lag_compensation else 0
        self._pause = max(2, int(round(cfg.pause_s * rate)))
        self._tmax = int(round(cfg.max_cycle_s * rate))
        self._gap = max(1, int(round(cfg.anchor_gap_s * rate)))
        self._init = max(2, int(round(0.25 * self.fps)))  # as stream_features
        self._idx = None
        self._bridge = None  # lost joints bridged (rep_bridge), made with the joint lookup
        self._waits = {}  # counter frame -> frames received when it was released, if later
        self._scale = None
        self._pending = []
        self._st = np.zeros((cfg.max_anchors, 3), dtype=np.int64)
        self._Mm = np.zeros((cfg.max_anchors, 2))
        self._na = np.zeros(1, dtype=np.int64)
        self._closed = np.zeros((cfg.max_anchors, 4))
        self._pos = 0  # last decimated frame the tracker processed
        self._search = True
        self._origin = 0
        self._cands = {}
        self._cur = None
        self._unliked = None
        self._skip = None  # start of the fidgets since the set's last repetition
        self._lead = 0.0  # share of a repetition the current set's uncounted lead-in moved
        self._events = []
        self.n_seen_ = 0
        self.count_ = 0
        self.sets_ = []
        self.n_loops_ = 0
        self.best_dissimilarity_ = np.inf
        self.near_misses_ = {}
        self.max_excursion_ = 0.0
        self._final = False  # finish() ran: the last frames count to the stream's end

    # --- input ---------------------------------------------------------------------------

    def learn_one(self, x) -> list[RepEvent]:
        """One frame: positions (n_joints, 3), or a feature row (d,) without a skeleton."""
        return self.learn_many(np.asarray(x, dtype=np.float64)[None])

    def learn_many(self, X) -> list[RepEvent]:
        """Frames: positions (n, n_joints, 3), or feature rows (n, d) without a skeleton.
        Returns the repetitions reported meanwhile."""
        X = np.asarray(X, dtype=np.float64)
        if self._names is not None:
            if X.ndim != 3 or X.shape[1:] != (len(self._names), 3):
                raise ParameterError(
                    f"positions must have shape (n, {len(self._names)}, 3); got {X.shape}"
                )
        elif X.ndim != 2 or (self._ring.Z is not None and X.shape[1] != self._ring.Z.shape[1]):
            raise ParameterError(
                f"feature rows must have shape (n, d) with one d throughout; got {X.shape}"
            )
        if X.shape[0] == 0:
            return []
        self._events = []
        self._learn(self._features(X))
        return self._events

    def _learn(self, F):
        if F is None:
            return
        # the ring holds buffer_s: push a few seconds at a time and track them before the
        # next ones overwrite what the tracker may still look back at
        step = max(1, (self._ring.C // 4) * self._ring.dec)
        for i in range(0, F.shape[0], step):
            self._push(F[i : i + step])
            self._run()

    def _push(self, F):
        fresh = self._ring.k < 0
        self._ring.push(F, self.n_seen_)
        self.n_seen_ += F.shape[0]
        if fresh and self._ring.k >= 0:
            self._set_anchors([0], 0)

    # --- the tracker -----------------------------------------------------------------------

    def _run(self):
        cfg, ring = self.config, self._ring
        while self._pos < ring.k:
            if self._search:
                thr, timeout = cfg.min_amplitude, self._tmax
            else:
                thr = max(
                    cfg.min_amplitude, cfg.amplitude_ratio * float(np.median(self._cur[2][-5:]))
                )
                med = float(np.median([b - a for a, b in self._cur[1]]))
                timeout = min(self._tmax, int(cfg.timeout_cycles * med))
            t, n = K.advance(
                ring.Z,
                ring.SP,
                self._pos + 1,
                ring.k + 1,
                self._search,
                self._st,
                self._Mm,
                self._na,
                thr,
                timeout,
                cfg.return_ratio,
                cfg.rise_ratio,
                cfg.rise_min,
                cfg.rest_level,
                self._pause,
                self._tmax,
                self._gap,
                cfg.max_anchors,
                self._closed,
            )
            self._pos = t
            self._now = t * ring.dec + 1  # frames seen when frame t decided (any chunking)
            for i in range(self._na[0]):
                self.max_excursion_ = max(self.max_excursion_, float(self._Mm[i, 0]))
            if n:
                loops = [(int(r[0]), int(r[1]), int(r[2]), float(r[3])) for r in self._closed[:n]]
                self.max_excursion_ = max(self.max_excursion_, max(lp[3] for lp in loops))
                if self._search:
                    self._on_search(loops, t)
                else:
                    self._on_track(loops[0], t)

    def _set_anchors(self, frames, t):
        """Anchors at ``frames``, caught up to frame ``t``."""
        frames = frames[-self.config.max_anchors :]
        for i, s in enumerate(frames):
            M, tM, m, tm = K.seed_anchor(self._ring.Z, s, t)
            self._st[i] = (s, tM, tm)
            self._Mm[i] = (M, m)
        self._na[0] = len(frames)

    def _search_from(self, s):
        """Look for a set from frame ``s`` on (the frames after it are gone through again)."""
        self._search = True
        self._origin = s
        self._pos = s
        self._set_anchors([s], s)
        self._cands = {k: v for k, v in self._cands.items() if k == s}

    def _track_from(self, cut, t):
        self._search = False
        self._set_anchors([cut], t)

    def _on_search(self, loops, t):
        for s, kind, cut, M in loops:
            self.n_loops_ += 1
            loop = (s, cut, M)
            prev = self._cands.get(s)
            r = self._ring.dissimilarity(prev, loop) if prev else None
            if r is not None:
                self.best_dissimilarity_ = min(self.best_dissimilarity_, r)
            if (
                r is not None
                and r <= self.config.max_dissimilarity
                and self._alike_pair(prev, loop)
            ):
                self._start_set(prev, loop, r)
                self._cands = {}
                if kind == K.PAUSE:
                    self._end_set("pause")
                    self._search_from(cut)
                else:
                    self._track_from(cut, t)
                return
            self._cands[cut] = loop
            n = self._na[0]
            if kind != K.PAUSE and cut not in self._st[:n, 0]:
                frames = sorted(self._st[:n, 0].tolist() + [cut])
                self._set_anchors(frames, t)
        self._cands = {k: v for k, v in self._cands.items() if t - k <= self._tmax}

    def _alike_pair(self, p, q, tempo=True) -> bool:
        """Whether alike loops ``p``, ``q`` pass :meth:`PoseRing.spread` (without its tempo
        test for a piece at the stream's edge, cut short by it: the edge test's
        ``edge_ratio`` holds instead); a failure is tallied in ``near_misses_`` (the reason a
        take without a set is given)."""
        fault = self._ring.spread_fault(p, q, tempo)
        if fault:
            self.near_misses_[fault] = self.near_misses_.get(fault, 0) + 1
        return not fault

    def _on_track(self, loop, t):
        s, kind, cut, M = loop
        if kind == K.TIMEOUT:
            if self._skip is not None:
                s = self._skip
            self._end_set("timeout")
            self._search_from(s)
            return
        self.n_loops_ += 1
        new = (s, cut, M)
        r = self._ring.dissimilarity(self._last(), new)
        pair = self._two_in_one(new, r)
        if pair is not None:
            self._add(*pair[0])
            new, r = pair[1]
        if kind == K.CLOSE and r > self.config.max_dissimilarity and self._fidget(new):
            # a small movement in the rest between repetitions: no repetition, no end of the
            # set; the next repetition is reported from where this one began
            if self._skip is None:
                self._skip = s
            self._track_from(cut, t)
            return
        if r <= self.config.max_dissimilarity:
            self._add(new, r)
            if kind == K.PAUSE:
                self._end_set("pause")
                self._search_from(cut)
            else:
                self._track_from(cut, t)
        else:
            cur, last = self._cur, self._last()
            if self._skip is not None:  # the fidgets may have begun the next set
                s = self._skip
            self._end_set("unlike")
            self._unliked = (cur, last, s)
            self._cands = {s: None}
            self._search_from(s)

    def _two_in_one(self, loop, r):
        """((first, dissimilarity), (second, dissimilarity)) when ``loop``, at least
        ``split_ratio`` as long as the set's median repetition, is two repetitions: cut where
        the pose comes closest back to its start's (:meth:`PoseRing.split`), both pieces alike
        the one before them, each more alike than the whole loop; else None."""
        f, ring = self.config.split_ratio, self._ring
        if not f:
            return None
        med = float(np.median(self._cur[3][-5:]))
        if loop[1] - loop[0] < f * med or ring.length(loop) < f * med:  # moving <= all
            return None
        parts = ring.split(loop)
        if parts is None:
            return None
        r1 = ring.dissimilarity(self._last(), parts[0])
        r2 = ring.dissimilarity(parts[0], parts[1])
        lim = self.config.max_dissimilarity
        if max(r1, r2) > lim:
            return None
        return (parts[0], r1), (parts[1], r2)

    def _fidget(self, loop) -> bool:
        """Whether ``loop``, unlike the set's last repetition, is a fidget: moving less than
        ``fidget_ratio`` as long as the set's median repetition, within the set's timeout of
        its last repetition's end."""
        f = self.config.fidget_ratio
        if not f:
            return False
        spans = self._cur[1]
        med = float(np.median(self._cur[3][-5:]))
        dur = float(np.median([b - a for a, b in spans]))
        if loop[1] - spans[-1][1] > self.config.timeout_cycles * dur:
            return False
        return self._ring.length(loop) < f * med


def warmup() -> None:
    """Compile the counter's kernels (a few seconds the first time, then cached)."""
    rng = np.random.default_rng(0)
    K.pose_features(
        frames_in(rng.normal(size=(2, 14, 3))),
        np.arange(14, dtype=np.int64),
        K.BONES,
        np.array([0.0, 1.0, 0.0]),
        1.0,
        np.empty((2, K.N_FEATURES)),
    )
    c = RepetitionCounter(fps=30.0)
    t = np.arange(300) / 30.0
    X = np.column_stack([np.sin(2 * np.pi * t / 1.5), np.cos(2 * np.pi * t / 1.5)]) * 1.5
    c.learn_many(X + rng.normal(0, 0.01, X.shape))
    c.finish()
