"""Live repetition counting: ``rep`` events a bounded delay after each repetition ends.

How it works. Frames go through a causal (forward-only) kinematic UKF; the bone directions of
the last ``buffer_s`` are analysed every ``hop_s`` with the offline steps of
section 4 (primary frequency, parameter selection, band-pass, candidates, adaptive k-means,
eq. 14).

"Repetitive" test: the offline one (:func:`streamseg.offline.rep_analysis.
not_repetitive_reason`) on the buffer: at least ``min_cycles + 0.5`` cycles of its primary
frequency (a primary frequency at the lowest admissible bin may be a longer period cut short),
half the primary frequency has less than ``max_subharmonic`` of its power (else the "primary"
is a harmonic of a movement not yet seen twice), and the band of ``band_width_cycles`` around
it holds at least ``min_concentration`` of the summed (detrended) power of all parameters
above ``min_cycles``; a new set also needs its boundaries to cut the buffer into at least
``min_cycles + 0.5`` pieces (:func:`streamseg.offline.rep_analysis.min_repetitions`, as
offline). While it fails nothing is emitted; after a whole buffer without passing,
the running count restarts at 0 (a new set). At the stream's end :meth:`RepetitionCounter.
finish` reports the repetitions the last frames hold.

Delay. Once a set is recognised (its first events may catch up on repetitions already in the
buffer), the next boundary is looked for one period after the last. A boundary marked by a
velocity minimum (a candidate) at frame ``e`` is reported at the first analysis at or after
``e + settle``, ``settle = ceil(0.5 * period)`` (the zero-phase band-pass needs half a cycle
after a minimum to place it): delay <= 0.5 period + hop. With no candidate near, the rhythm
places the boundary at last + period, reported once 0.35 period more have passed: delay <=
0.85 period + hop. The period is at most ``buffer_s / (min_cycles + 0.5)`` (4.8 s by
default), so every delay is below 4.6 s; for paces of 0.5-2 s per repetition it is about
0.5-1.5 s. ``RepEvent.emitted_at`` is the frame index at which the event was made.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from streamseg.config import RepetitionConfig
from streamseg.exceptions import ParameterError
from streamseg.kinematics.model import bone_directions, estimate_noise, limb_points, observations
from streamseg.kinematics.tracker import AngleTracker
from streamseg.offline.rep_analysis import analyse, min_repetitions, not_repetitive_reason
from streamseg.offline.repetition_steps import to_repetitions

__all__ = ["RepEvent", "RepetitionCounter"]


@dataclass(frozen=True)
class RepEvent:
    """One repetition found live.

    Attributes
    ----------
    start, end : int
        Stream frame indices (0-based, end exclusive).
    count : int
        Running count in the current set, this repetition included.
    emitted_at : int
        Stream frame index at which the event was made (``emitted_at - end`` is the delay).
    """

    start: int
    end: int
    count: int
    emitted_at: int


class RepetitionCounter:
    """Count repetitions in a live joint-position stream.

    Parameters
    ----------
    config : RepetitionConfig, optional
    fps : float
    skeleton : Skeleton or sequence of str
        Joint names of the incoming frames (Acclaim bone names, positions at bone ends).

    Attributes
    ----------
    n_seen_ : int
        Frames received.
    count_ : int
        Running count of the current set.
    repetitive_ : bool
        Outcome of the last "repetitive" test.
    """

    def __init__(self, config: RepetitionConfig | None = None, fps: float = 120.0,
                 skeleton=None):
        if not fps or fps <= 0:
            raise ParameterError(f"fps={fps!r} is invalid: expected the stream's frame rate > 0")
        if skeleton is None:
            raise ParameterError("skeleton=None is invalid: pass the stream's Skeleton (or its "
                                 "joint names)")
        self.config = config or RepetitionConfig()
        # Live the buffer's ends are wherever the stream is, not a rest pose: boundaries are
        # refined to velocity minima (the offline "rest" refinement needs the take's ends).
        self._analysis_config = replace(self.config, refine_to="speed",
                                        refine_fraction=self.config.live_refine_fraction)
        self.fps = float(fps)
        self._names = tuple(getattr(skeleton, "names", skeleton))
        self._cap = int(round(self.config.buffer_s * self.fps))
        self._hop = max(1, int(round(self.config.hop_s * self.fps)))
        self._init = max(2, int(round(0.25 * self.fps)))  # frames that fix body scale etc.
        self._pending = []
        self._dirs = np.empty((0, 30))
        self._tracker = None
        self._scale = self._pdir = None
        self.n_seen_ = 0
        self.count_ = 0
        self.repetitive_ = False
        self._last_end = None
        self._since_repetitive = 0
        self._next_analysis = None

    def learn_one(self, positions) -> list[RepEvent]:
        """One frame, shape (n_joints, 3)."""
        return self.learn_many(np.asarray(positions, dtype=np.float64)[None])

    def learn_many(self, positions) -> list[RepEvent]:
        """Frames, shape (n, n_joints, 3); returns the repetitions completed meanwhile."""
        P = np.asarray(positions, dtype=np.float64)
        if P.ndim != 3 or P.shape[1:] != (len(self._names), 3):
            raise ParameterError(f"positions must have shape (n, {len(self._names)}, 3); got "
                                 f"{P.shape}")
        events = []
        # Analyses happen at hop boundaries inside the chunk so a big chunk behaves like
        # many small ones (same events, same emitted_at).
        i = 0
        while i < P.shape[0]:
            if self._next_analysis is None:  # still collecting the first frames
                take = min(P.shape[0] - i, self._init - self.n_seen_)
            else:
                take = min(P.shape[0] - i, max(1, self._next_analysis - self.n_seen_))
            self._ingest(P[i:i + take])
            i += take
            if self._next_analysis is not None and self.n_seen_ >= self._next_analysis:
                events.extend(self._analyse())
                self._next_analysis += self._hop
        return events

    def _ingest(self, P):
        if self._tracker is None:
            self._pending.append(P)
            buf = np.concatenate(self._pending)
            self.n_seen_ += P.shape[0]
            if buf.shape[0] < self._init:
                return
            # Body scale, pelvis direction and initial bone lengths from exactly the first
            # frames, so the events do not depend on how the stream is chunked.
            pts = limb_points(buf[: self._init], self._names)
            _, self._scale, self._pdir, l0 = observations(pts, self.fps, None)
            cfg = self.config
            noise = cfg.position_noise
            if cfg.estimate_noise:  # as offline, from the jitter of the first frames
                noise = max(noise, estimate_noise(buf[: self._init], self._scale))
            self._tracker = AngleTracker(self.fps, self._pdir, l0,
                                         position_noise=noise,
                                         angle_speed=cfg.angle_speed,
                                         length_speed=cfg.length_speed)
            self._pending = []
            self._push(buf)
            self._next_analysis = self.n_seen_ + self._hop
            return
        self.n_seen_ += P.shape[0]
        self._push(P)

    def _push(self, P):
        pts = limb_points(P, self._names)
        Y, _, _, _ = observations(pts, self.fps, None, scale=self._scale,
                                  pelvis_dir=self._pdir)
        d = bone_directions(self._tracker.update(Y))
        self._dirs = np.concatenate([self._dirs, d])[-self._cap:]

    def _analyse(self) -> list[RepEvent]:
        cfg = self.config
        X = self._dirs
        n = X.shape[0]
        start = self.n_seen_ - n  # stream frame of X[0]
        ok = n >= self.fps  # at least a second of motion before any test
        a = None
        if ok:
            try:
                a = analyse(X, self.fps, self._analysis_config)
            except ParameterError:
                a = None
        # A primary frequency pinned at the lowest admissible bin means the true period may be
        # longer than the buffer allows: not (yet) evidence of repetition.
        self.repetitive_ = bool(a is not None and self._repetitive(a))
        if not self.repetitive_:
            self._since_repetitive += self._hop
            if self._since_repetitive >= self._cap:
                self.count_, self._last_end = 0, None
            return []
        self._since_repetitive = 0
        settle = int(np.ceil(0.5 * a.period))
        done = self.n_seen_ - settle  # boundaries up to here are final
        out = []
        if self._last_end is None:
            # First repetitions of a set: the offline rule on the buffer.
            reps = to_repetitions(a.boundaries, n, a.period, cfg.edge_fraction, a.speed2)
            if len(reps) < min_repetitions(cfg):
                # the offline rule on the pieces too: fewer than min_cycles + 0.5 is no set
                self.repetitive_ = False
                return []
            for s, e in reps:
                if e + start > done:
                    break
                # Early buffers hold few cycles: a piece far from one period is not yet a
                # repetition (usually the part before the rhythm set in).
                if out or 0.6 * a.period <= e - s <= 1.6 * a.period:
                    out.append(self._emit(s + start, e + start))
            return out
        # Afterwards keep the rhythm (and the phase) of the set: the next boundary is the
        # candidate nearest one period after the last, preferring the eq. 14 group; with no
        # candidate there the rhythm itself places it (as offline gap filling does).
        group = set((a.boundaries + start).tolist())
        cands = a.candidates + start
        while self._last_end + 1.35 * a.period <= done or (
                self._last_end + a.period <= done and cands.size
                and np.any(np.abs(cands - self._last_end - a.period) <= 0.35 * a.period)):
            pred = self._last_end + a.period
            near = cands[np.abs(cands - pred) <= 0.35 * a.period]
            near = near[near <= done]
            preferred = [c for c in near if c in group]
            pool = preferred or near.tolist()
            e = min(pool, key=lambda c: abs(c - pred)) if pool else int(round(pred))
            if e <= self._last_end:
                break
            out.append(self._emit(self._last_end, int(e)))
        return out

    def _repetitive(self, a) -> bool:
        """The offline test, :func:`not_repetitive_reason` (a floor of 0.5 on the power
        concentration, as before, silenced 31% of the Kinect-like sequences:
        ``benchmarks/repetitions.py --live``)."""
        return not not_repetitive_reason(a, self.config)

    def finish(self) -> list[RepEvent]:
        """The stream has ended: the repetitions its last frames still hold.

        Live, a repetition is reported half a period after it ends; the last ones of a
        stream never are. At the end the buffer is cut by the offline rule (the sequence
        taken to end at a repetition boundary, ``merge_edges``): the repetitions after the
        last one reported are emitted (``emitted_at`` = the frames seen), up to the first
        piece longer than two periods. Only when the buffer passes the repetitive test. When
        the last analysis did not (no set under way), the end's repetitions are a new set
        (the count restarts), taken as live takes a set's first ones: pieces of 0.6-1.6
        periods.
        """
        cfg = self.config
        X = self._dirs
        n = X.shape[0]
        if self._tracker is None or n < self.fps:
            return []
        try:
            a = analyse(X, self.fps, self._analysis_config)
        except ParameterError:
            return []
        if not self._repetitive(a):
            return []
        start = self.n_seen_ - n
        reps = to_repetitions(a.boundaries, n, a.period, cfg.edge_fraction, a.speed2,
                              merge_edges=True)
        under_way = self._last_end is not None and self.repetitive_
        if not under_way and len(reps) < min_repetitions(cfg):
            return []  # a new set needs as many pieces as offline (min_repetitions)
        if not under_way and self._last_end is not None:
            # the last analysis was not repetitive: what the end holds is a new set
            self.count_, first = 0, self._last_end
            self._last_end = None
        else:
            first = None
        out = []
        for s, e in reps:
            s, e = s + start, e + start
            if under_way:
                if e - self._last_end < 0.5 * a.period:
                    continue  # reported already (or the rest of one that was)
                s = self._last_end
                if e - s > 2.0 * a.period:
                    break  # not one repetition of the set's rhythm (a pause, another action)
            else:  # a new set: as its first repetitions live, each near one period
                if first is not None and s < first:
                    continue
                if not 0.6 * a.period <= e - s <= 1.6 * a.period:
                    if out:
                        break
                    continue
            out.append(self._emit(s, e))
        return out

    def _emit(self, s, e) -> RepEvent:
        self.count_ += 1
        self._last_end = int(e)
        return RepEvent(int(s), int(e), self.count_, self.n_seen_)
