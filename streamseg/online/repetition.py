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
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from streamseg._kernels import frames_in
from streamseg._kernels import rep_track as K
from streamseg.config import RepetitionConfig
from streamseg.exceptions import ParameterError

__all__ = ["RepEvent", "RepSet", "RepetitionCounter", "pose_features", "sets_of",
           "stream_events", "stream_features"]


@dataclass(frozen=True)
class RepEvent:
    """One repetition found live.

    Attributes
    ----------
    start, end : int
        Counter frame indices (0-based, end exclusive).
    count : int
        The repetition's number in its set (1 = the first).
    emitted_at : int
        Frames the counter had seen when it decided (``emitted_at - end`` is the delay),
        whatever the chunks the frames came in.
    set_index : int
        0-based index of its set in the stream.
    """

    start: int
    end: int
    count: int
    emitted_at: int
    set_index: int = 0


@dataclass
class RepSet:
    """A set: consecutive repetitions of one movement.

    Attributes
    ----------
    repetitions : list of (int, int)
        Frames, 0-based, end exclusive.
    dissimilarity : list of float
        DTW distance / amplitude of each repetition to the one before (first: None).
    end_reason : str
        Why the set ended: "unlike" (the next loop differs), "pause", "timeout", "end".
    """

    repetitions: list = field(default_factory=list)
    dissimilarity: list = field(default_factory=list)
    end_reason: str = ""

    @property
    def start(self) -> int:
        return self.repetitions[0][0]

    @property
    def end(self) -> int:
        return self.repetitions[-1][1]

    @property
    def count(self) -> int:
        return len(self.repetitions)


def stream_features(recording, fps=None) -> np.ndarray:
    """The pose features a counter computes for ``recording``'s frames (its body size from
    the first 0.25 s, as live): a counter built without a skeleton on them counts the same."""
    fps = float(recording.fps if fps is None else fps)
    init = max(2, int(round(0.25 * fps)))
    from streamseg.skeleton.names import POINTS, resolve

    P = np.ascontiguousarray(recording.positions, dtype=np.float64)
    idx = np.asarray(resolve(list(recording.skeleton.names), K.POINTS, POINTS), dtype=np.int64)
    return pose_features(P, recording.skeleton.names, recording.skeleton.up,
                         scale=body_scale(P[:init], idx))


def pose_features(positions, names, up="y", scale=None):
    """The counter's pose vector of every frame (before the low-pass).

    Parameters
    ----------
    positions : ndarray, shape (n, n_joints, 3)
    names : sequence of str
        Joint names (any skeleton :func:`streamseg.skeleton.names.resolve` maps).
    up : str
        World up axis (``Skeleton.up``).
    scale : float, optional
        Body size (thigh length, positions' units); default: from these frames.

    Returns
    -------
    ndarray, shape (n, 28)
        See :func:`streamseg._kernels.rep_track.pose_features`.
    """
    from streamseg.skeleton.bones import up_vector
    from streamseg.skeleton.names import POINTS, resolve

    P = frames_in(positions)
    idx = np.asarray(resolve(list(names), K.POINTS, POINTS), dtype=np.int64)
    if scale is None:
        scale = body_scale(P, idx)
    out = np.empty((P.shape[0], K.N_FEATURES))
    K.pose_features(P, idx, K.BONES, np.asarray(up_vector(up), dtype=np.float64), float(scale),
                    out)
    return out


def body_scale(P, idx) -> float:
    """Median thigh length over frames ``P``; 1.0 when undefined."""
    th = np.concatenate([np.linalg.norm(P[:, idx[10]] - P[:, idx[2]], axis=1),
                         np.linalg.norm(P[:, idx[12]] - P[:, idx[3]], axis=1)])
    th = th[np.isfinite(th) & (th > 0)]
    return float(np.median(th)) if th.size else 1.0


class RepetitionCounter:
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
    max_excursion_ : float
        Farthest the pose went from any anchor.
    """

    def __init__(self, config: RepetitionConfig | None = None, fps: float = 120.0,
                 skeleton=None):
        if not np.isscalar(fps) or not fps > 0:
            raise ParameterError(f"fps={fps!r} is invalid: expected the stream's frame rate > 0")
        self.config = cfg = config or RepetitionConfig()
        self.fps = float(fps)
        self._names = None if skeleton is None else tuple(getattr(skeleton, "names", skeleton))
        self._up = getattr(skeleton, "up", "y")
        self._dec = max(1, int(round(self.fps / cfg.rate_hz)))
        rate = self.fps / self._dec
        self._rate = rate
        from scipy.signal import butter

        self._sos = butter(2, min(cfg.lowpass_hz, 0.45 * self.fps), fs=self.fps, output="sos")
        delay = np.sqrt(2.0) / (2 * np.pi * cfg.lowpass_hz)  # the filter's delay at low rates
        self._lag = int(round(delay * self.fps)) if cfg.lag_compensation else 0
        self._pause = max(2, int(round(cfg.pause_s * rate)))
        self._tmax = int(round(cfg.max_cycle_s * rate))
        self._gap = max(1, int(round(cfg.anchor_gap_s * rate)))
        self._C = int(round(cfg.buffer_s * rate)) + 2
        self._init = max(2, int(round(0.25 * self.fps)))  # as stream_features
        self._idx = None
        self._scale = None
        self._pending = []
        self._state = None
        self._Z = None
        self._SP = np.zeros(self._C)
        self._st = np.zeros((cfg.max_anchors, 3), dtype=np.int64)
        self._Mm = np.zeros((cfg.max_anchors, 2))
        self._na = np.zeros(1, dtype=np.int64)
        self._closed = np.zeros((cfg.max_anchors, 4))
        self._k = -1  # newest decimated frame
        self._pos = 0  # last decimated frame the tracker processed
        self._search = True
        self._origin = 0
        self._cands = {}
        self._cur = None
        self._events = []
        self.n_seen_ = 0
        self.count_ = 0
        self.sets_ = []
        self.n_loops_ = 0
        self.best_dissimilarity_ = np.inf
        self.max_excursion_ = 0.0

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
                raise ParameterError(f"positions must have shape (n, {len(self._names)}, 3); "
                                     f"got {X.shape}")
        elif X.ndim != 2 or (self._Z is not None and X.shape[1] != self._Z.shape[1]):
            raise ParameterError(f"feature rows must have shape (n, d) with one d throughout; "
                                 f"got {X.shape}")
        if X.shape[0] == 0:
            return []
        self._events = []
        F = self._features(X)
        if F is not None:
            # the ring holds buffer_s: push a few seconds at a time and track them before the
            # next ones overwrite what the tracker may still look back at
            step = max(1, (self._C // 4) * self._dec)
            for i in range(0, F.shape[0], step):
                self._push(F[i:i + step])
                self._run()
        return self._events

    def _features(self, X):
        if self._names is None:
            return X
        if self._idx is None:
            from streamseg.skeleton.names import POINTS, resolve

            self._idx = np.asarray(resolve(list(self._names), K.POINTS, POINTS), dtype=np.int64)
            self._upv = None
        if self._scale is None:  # body size from exactly the first frames: chunking-free
            self._pending.append(X)
            buf = np.concatenate(self._pending)
            if buf.shape[0] < self._init:
                return None
            self._pending = []
            self._scale = body_scale(buf[: self._init], self._idx)
            X = buf
        from streamseg.skeleton.bones import up_vector

        if self._upv is None:
            self._upv = np.asarray(up_vector(self._up), dtype=np.float64)
        out = np.empty((X.shape[0], K.N_FEATURES))
        K.pose_features(frames_in(X), self._idx, K.BONES, self._upv, self._scale,
                        out)
        return out

    def _push(self, F):
        if self._state is None:
            from scipy.signal import sosfilt_zi

            # start at rest on the first frame (no transient from zero)
            self._state = sosfilt_zi(self._sos)[:, :, None] * F[0][None, None, :]
            self._Z = np.zeros((self._C, F.shape[1]))
        Y = np.empty_like(F)
        K.sos_filter(F, self._sos, self._state, Y)
        first = self.n_seen_
        fresh = self._k < 0
        self.n_seen_ += F.shape[0]
        # decimated frames: stream frames 0, dec, 2 dec, ...
        for f in range((-first) % self._dec, F.shape[0], self._dec):
            k = (first + f) // self._dec
            row = k % self._C
            self._Z[row] = Y[f]
            self._SP[row] = 0.0 if k == 0 else np.sqrt(np.sum((Y[f] - self._Z[(k - 1) % self._C])
                                                              ** 2))
            self._k = k
        if fresh and self._k >= 0:
            self._set_anchors([0], 0)

    # --- the tracker -----------------------------------------------------------------------

    def _run(self):
        cfg = self.config
        while self._pos < self._k:
            if self._search:
                thr, timeout = cfg.min_amplitude, self._tmax
            else:
                thr = max(cfg.min_amplitude,
                          cfg.amplitude_ratio * float(np.median(self._cur[2][-5:])))
                med = float(np.median([b - a for a, b in self._cur[1]]))
                timeout = min(self._tmax, int(cfg.timeout_cycles * med))
            t, n = K.advance(self._Z, self._SP, self._pos + 1, self._k + 1, self._search,
                             self._st, self._Mm, self._na, thr, timeout, cfg.return_ratio,
                             cfg.rise_ratio, cfg.rise_min, cfg.rest_level, self._pause,
                             self._tmax, self._gap, cfg.max_anchors, self._closed)
            self._pos = t
            self._now = t * self._dec + 1  # frames seen when frame t decided (any chunking)
            for i in range(self._na[0]):
                self.max_excursion_ = max(self.max_excursion_, float(self._Mm[i, 0]))
            if n:
                loops = [(int(r[0]), int(r[1]), int(r[2]), float(r[3]))
                         for r in self._closed[:n]]
                self.max_excursion_ = max(self.max_excursion_, max(lp[3] for lp in loops))
                if self._search:
                    self._on_search(loops, t)
                else:
                    self._on_track(loops[0], t)

    def _set_anchors(self, frames, t):
        """Anchors at ``frames``, caught up to frame ``t``."""
        frames = frames[-self.config.max_anchors:]
        for i, s in enumerate(frames):
            M, tM, m, tm = K.seed_anchor(self._Z, s, t)
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
            r = self._dissimilarity(prev, loop) if prev else None
            if r is not None:
                self.best_dissimilarity_ = min(self.best_dissimilarity_, r)
            if r is not None and r <= self.config.max_dissimilarity and self._spread(prev, loop):
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

    def _on_track(self, loop, t):
        s, kind, cut, M = loop
        if kind == K.TIMEOUT:
            self._end_set("timeout")
            self._search_from(s)
            return
        self.n_loops_ += 1
        new = (s, cut, M)
        r = self._dissimilarity(self._last(), new)
        if r <= self.config.max_dissimilarity:
            self._add(new, r)
            if kind == K.PAUSE:
                self._end_set("pause")
                self._search_from(cut)
            else:
                self._track_from(cut, t)
        else:
            self._end_set("unlike")
            self._cands = {s: None}
            self._search_from(s)

    def _last(self):
        (a, b), M = self._cur[1][-1], self._cur[2][-1]
        return (a, b, M)

    def _start_set(self, prev, loop, r):
        cfg = self.config
        loops, dis = [prev, loop], [None, r]
        while True:  # earlier loops chained to the first one, alike
            b = self._cands.get(loops[0][0])
            if b is None or b[2] < cfg.amplitude_ratio * np.median([x[2] for x in loops]):
                break
            if self._length(b) < 0.5 * self._length(loops[0]):
                break  # as an edge piece: at least half the next one
            rb = self._dissimilarity(b, loops[0])
            if rb > cfg.max_dissimilarity:
                break
            loops.insert(0, b)
            dis[0] = rb
            dis.insert(0, None)
        if cfg.extend_edges:
            piece = self._edge_before(loops[0])
            if piece is not None:
                loops.insert(0, piece[0])
                dis[0] = piece[1]
                dis.insert(0, None)
        loops[0] = self._trimmed(loops[0])
        self._cur = [RepSet(), [], []]
        self.sets_.append(self._cur[0])
        for lp, d in zip(loops, dis):
            self._add(lp, d)

    def _trimmed(self, loop):
        """The set's first loop starting at most ``pause_s / 2`` before the pose leaves the
        anchor's (a set does not begin with a long rest)."""
        a, b, M = loop
        d = np.linalg.norm(self._rows(a, b) - self._Z[a % self._C], axis=1)
        moved = np.flatnonzero(d > self.config.rest_level * M)
        if moved.size and moved[0] > self._pause // 2:
            a += int(moved[0]) - self._pause // 2
        return (a, b, M)

    def _add(self, loop, dis):
        a, b, M = loop
        st, spans, amps = self._cur
        spans.append((a, b))
        amps.append(M)
        st.repetitions.append((self._frame(a), self._frame(b)))
        st.dissimilarity.append(None if dis is None else float(dis))
        self.count_ = len(spans)
        self._events.append(RepEvent(st.repetitions[-1][0], st.repetitions[-1][1],
                                     self.count_, self._now, len(self.sets_) - 1))

    def _end_set(self, why):
        if self._cur is not None:
            self._cur[0].end_reason = why
            self._cur = None
        self.count_ = 0

    def _frame(self, k) -> int:
        """Stream frame of decimated frame ``k`` (the filter's delay taken off)."""
        if k <= 0:
            return 0
        if getattr(self, "_final", False) and k >= self._k:
            return self.n_seen_
        return max(0, k * self._dec - self._lag)

    # --- comparing loops -----------------------------------------------------------------

    def _rows(self, a, b):
        idx = np.arange(a, b + 1) % self._C
        return self._Z[idx]

    def _moving(self, p, vmax=None):
        """Frames ``p[0] .. p[1]`` where the pose moves, as stream-ring indices: those
        around a speed (3-frame mean) above ``still_ratio`` x ``vmax`` (default: the
        fastest in the span), and both ends. A rest inside a loop is thus no part of its
        duration nor of its shape."""
        a, b = p[0], p[1]
        idx = np.arange(a, b + 1)
        if b - a < 4:
            return idx
        v = self._speeds(a, b)
        moving = np.flatnonzero(v > self.config.still_ratio * (v.max() if vmax is None
                                                               else vmax))
        if moving.size < 2:
            return idx
        keep = np.zeros(idx.size, bool)
        keep[moving] = True
        keep[np.maximum(moving - 1, 0)] = True  # speed u is the step from u - 1 to u
        keep[0] = keep[-1] = True
        return idx[keep]

    def _speeds(self, a, b):
        v = self._SP[np.arange(a, b + 1) % self._C]
        return np.convolve(v, np.ones(3) / 3, mode="same")

    def _vmax(self, p) -> float:
        return float(self._speeds(p[0], p[1]).max())

    def _length(self, p) -> int:
        """Loop ``p``'s moving duration (decimated frames)."""
        return self._moving(p).size - 1

    def _mrows(self, p):
        return self._Z[self._moving(p) % self._C]

    def _resampled(self, p):
        A = self._mrows(p)
        L = min(self.config.resample, A.shape[0])
        x = np.linspace(0.0, A.shape[0] - 1.0, L)
        i = np.floor(x).astype(np.int64)
        j = np.minimum(i + 1, A.shape[0] - 1)
        w = (x - i)[:, None]
        return A[i] * (1.0 - w) + A[j] * w

    def _dissimilarity(self, p, q) -> float:
        """DTW distance of loops ``p`` and ``q`` ((start, end, amplitude)) / amplitude, their
        moving frames compared (a rest inside either is left out)."""
        cost = K.dtw_mean(self._resampled(p), self._resampled(q))
        return float(cost / max(0.5 * (p[2] + q[2]), 1e-12))

    def _spread(self, p, q) -> bool:
        """The larger loop spans ``spread_ratio`` of the range of both; the smaller is at
        least ``amplitude_ratio`` of it and moves at least 1 / ``start_tempo_ratio`` as long."""
        cfg = self.config
        da, db = self._length(p), self._length(q)
        if max(da, db) > cfg.start_tempo_ratio * min(da, db):
            return False
        W = self._rows(p[0], q[1])
        i = int(np.argmax(np.linalg.norm(W - W[0], axis=1)))
        span = float(np.linalg.norm(W - W[i], axis=1).max())
        big, small = max(p[2], q[2]), min(p[2], q[2])
        return big >= cfg.spread_ratio * span and small >= cfg.amplitude_ratio * big

    def _oldest(self) -> int:
        return max(0, self._k - self._C + 1)

    def _edge_before(self, first):
        """(piece, dissimilarity) before loop ``first`` that aligns with it, or None."""
        a, b = first[0], first[1]
        L = self._length(first)
        lo = max(self._origin, a - 2 * (b - a), self._oldest())
        idx = self._moving((lo, a), self._vmax(first))
        if idx.size - 1 < 0.5 * L:
            return None
        S = self._Z[idx % self._C]
        cost, j = K.edge_dtw(self._mrows(first), S)
        amp = float(np.linalg.norm(S[j:] - S[-1], axis=1).max())
        return self._edge_ok((int(idx[j]), a, amp), first, cost, L, idx.size - 1 - int(j))

    def _edge_after(self, last, a, t):
        """(piece, dissimilarity) after loop ``last`` from frame ``a`` to at most ``t`` that
        aligns with it, or None."""
        L = self._length(last)
        idx = self._moving((a, min(t, a + 2 * (last[1] - last[0]))), self._vmax(last))
        if idx.size - 1 < 0.5 * L:
            return None
        S = self._Z[idx % self._C]
        cost, j = K.edge_dtw(self._mrows(last)[::-1].copy(), S[::-1].copy())
        end = S.shape[0] - 1 - int(j)
        amp = float(np.linalg.norm(S[: end + 1] - S[0], axis=1).max())
        return self._edge_ok((a, int(idx[end]), amp), last, cost, L, end)

    def _edge_ok(self, piece, ref, cost, L, n):
        cfg = self.config
        if n < 0.5 * L or piece[2] < cfg.amplitude_ratio * ref[2]:
            return None
        r = float(cost / max(0.5 * (piece[2] + ref[2]), 1e-12))
        return (piece, r) if r <= cfg.max_dissimilarity else None

    # --- end of stream ---------------------------------------------------------------------

    def finish(self) -> list[RepEvent]:
        """The stream has ended: the repetition its last frames still hold, if any.

        In a set, the last loop counts when it came back within ``end_return_ratio`` (cut at
        its rest, at most ``pause_s / 2`` in, or at the end), or, with ``extend_edges``, when
        the frames after the last cut align with the last repetition. Looking for a set, the
        same for a loop after a closed one.
        """
        self._events = []
        if self._Z is None or self._k < 1:
            return []
        self._final = True
        self._now = self.n_seen_
        cfg = self.config
        t = self._k
        n = self._na[0]
        if not self._search and self._cur is not None:
            loop = self._last_loop(0, t, True)
            r = None if loop is None else self._dissimilarity(self._last(), loop)
            if r is not None and r <= cfg.max_dissimilarity:
                self._add(loop, r)
            elif cfg.extend_edges:
                piece = self._edge_after(self._last(), int(self._st[0, 0]), t)
                if piece is not None:
                    self._add(*piece)
            self._end_set("end")
        elif self._search:
            done = False
            for i in range(n):
                prev = self._cands.get(int(self._st[i, 0]))
                loop = self._last_loop(i, t, False) if prev else None
                if loop is None:
                    continue
                r = self._dissimilarity(prev, loop)
                if r <= cfg.max_dissimilarity and self._spread(prev, loop):
                    self._start_set(prev, loop, r)
                    done = True
                    break
            if not done and cfg.extend_edges:
                for e in sorted(self._cands, reverse=True):
                    prev = self._cands[e]
                    if prev is None:
                        continue
                    piece = self._edge_after(prev, e, t)
                    if piece is not None and self._spread(prev, piece[0]):
                        self._start_set(prev, piece[0], piece[1])
                        break
            self._end_set("end")
        return self._events

    def _last_loop(self, i, t, in_set):
        """Anchor ``i``'s loop at the end of the stream, leniently closed, or None."""
        cfg = self.config
        s = int(self._st[i, 0])
        M, m = float(self._Mm[i, 0]), float(self._Mm[i, 1])
        tM, tm = int(self._st[i, 1]), int(self._st[i, 2])
        thr = cfg.min_amplitude
        if in_set:
            thr = max(thr, cfg.amplitude_ratio * float(np.median(self._cur[2][-5:])))
        if M < thr or not m <= cfg.end_return_ratio * M:
            return None
        cut = t
        if m <= cfg.return_ratio * M:
            level = m + cfg.rest_level * (M - m)
            d = np.linalg.norm(self._rows(s, t) - self._Z[s % self._C], axis=1)
            e, x = tm - s, tm - s
            while e - 1 > tM - s and d[e - 1] <= level:
                e -= 1
            while x + 1 <= t - s and d[x + 1] <= level:
                x += 1
            if x >= t - s - 1:
                cut = min(t, s + e + self._pause // 2)
            else:
                sp = np.linalg.norm(self._rows(s + e + 1, s + x + 1)
                                    - self._rows(s + e - 1, s + x - 1), axis=1)
                cut = s + e + int(np.argmin(sp))
        return (s, cut, M)


def stream_events(counter: RepetitionCounter, X, chunk: int) -> list[RepEvent]:
    """Every event of ``counter`` fed ``X`` ``chunk`` frames a call, then finished (what a
    stream in packets of ``chunk`` frames gets; the sets do not depend on ``chunk``)."""
    events = []
    for i in range(0, len(X), chunk):
        events += counter.learn_many(X[i:i + chunk])
    return events + counter.finish()


def sets_of(events) -> list:
    """The repetitions ``(start, end)`` of each set, by ``set_index``, from events."""
    out: dict = {}
    for e in events:
        out.setdefault(e.set_index, []).append((e.start, e.end))
    return [out[i] for i in sorted(out)]


def warmup() -> None:
    """Compile the counter's kernels (a few seconds the first time, then cached)."""
    rng = np.random.default_rng(0)
    K.pose_features(frames_in(rng.normal(size=(2, 14, 3))), np.arange(14, dtype=np.int64),
                    K.BONES, np.array([0.0, 1.0, 0.0]), 1.0, np.empty((2, K.N_FEATURES)))
    c = RepetitionCounter(fps=30.0)
    t = np.arange(300) / 30.0
    X = np.column_stack([np.sin(2 * np.pi * t / 1.5), np.cos(2 * np.pi * t / 1.5)]) * 1.5
    c.learn_many(X + rng.normal(0, 0.01, X.shape))
    c.finish()
