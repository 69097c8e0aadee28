"""A set's repetitions for the repetition counter: how a set starts, resumes and grows.

:class:`~streamseg.online.repetition.RepetitionCounter` takes these from here. A set starts
at two alike loops (:meth:`SetRecords._start_set`) with the earlier loops chained to the
first one and, with ``extend_edges``, the piece before it when it aligns and moves at least
``edge_ratio`` as long; a shorter aligned piece is the set's *lead-in* (``_lead``, its share
of a repetition), which the piece after the set's last repetition at the stream's end
completes (:mod:`streamseg.online.rep_stream_end`). A set that ended at an unlike loop
resumes (:meth:`SetRecords._resumed`). Each repetition is recorded with its event
(:meth:`SetRecords._add`).
"""

from __future__ import annotations

import numpy as np

from streamseg.online.rep_events import RepEvent, RepSet
from streamseg.online.rep_pose import ROM_JOINTS, joint_ranges

__all__ = ["SetRecords"]


class SetRecords:
    """The set bookkeeping of :class:`~streamseg.online.repetition.RepetitionCounter`."""

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
            if self._ring.length(b) < 0.5 * self._ring.length(loops[0]):
                break  # as an edge piece: at least half the next one
            rb = self._ring.dissimilarity(b, loops[0])
            if rb > cfg.max_dissimilarity:
                break
            loops.insert(0, b)
            dis[0] = rb
            dis.insert(0, None)
        lead = 0.0
        if cfg.extend_edges:
            piece = self._ring.edge_piece_before(loops[0], self._origin, 0.0, False)
            if (
                piece is not None
                and piece[2] >= cfg.edge_ratio
                and piece[0][2] >= cfg.amplitude_ratio * loops[0][2]
            ):
                loops.insert(0, piece[0])
                dis[0] = piece[1]
                dis.insert(0, None)
            elif piece is not None:
                lead = piece[2]
        if self._resumed(loops, dis):
            return
        self._lead = lead
        loops[0] = self._trimmed(loops[0])
        self._cur = [RepSet(), [], [], []]  # the set, spans, amplitudes, moving lengths
        self.sets_.append(self._cur[0])
        if self._names is not None:  # the joint that moves most over the first loops
            rom = np.median([joint_ranges(self._ring.rows(a, b)) for a, b, _ in loops], axis=0)
            self._cur[0].rom_joint = ROM_JOINTS[int(np.argmax(rom))][0]
        for i, (lp, d) in enumerate(zip(loops, dis)):
            self._add(lp, d, dis[1] if i == 0 and len(dis) > 1 else None)

    def _resumed(self, loops, dis) -> bool:
        """The set that ended at an unlike loop goes on with ``loops`` when they start within
        one of its repetitions of its end and the first is within ``resume_dissimilarity``
        of its last repetition (one bout, one set: a noisy or odd repetition in the middle of
        a bout does not split it)."""
        u, self._unliked = self._unliked, None
        if not self.config.resume_dissimilarity or u is None:
            return False
        cur, last, end = u
        first = loops[0]
        if first[0] - end > last[1] - last[0] or last[0] < self._ring._oldest():
            return False
        r = self._ring.dissimilarity(last, first)
        if r > self.config.resume_dissimilarity:
            return False
        self._cur = cur
        cur[0].end_reason = ""
        dis = [r] + list(dis[1:])
        for lp, d in zip(loops, dis):
            self._add(lp, d)
        return True

    def _trimmed(self, loop):
        """The set's first loop starting at most ``pause_s / 2`` before the pose leaves the
        anchor's (a set does not begin with a long rest)."""
        a, b, M = loop
        d = np.linalg.norm(self._ring.rows(a, b) - self._ring.Z[a % self._ring.C], axis=1)
        moved = np.flatnonzero(d > self.config.rest_level * M)
        if moved.size and moved[0] > self._pause // 2:
            a += int(moved[0]) - self._pause // 2
        return (a, b, M)

    def _add(self, loop, dis, next_dis=None):
        a, b, M = loop
        st, spans, amps, lengths = self._cur
        spans.append((a, b))
        amps.append(M)
        lengths.append(self._ring.length(loop))
        start = a if self._skip is None else self._skip
        self._skip = None
        st.repetitions.append((self._frame(start), self._frame(b)))
        st.dissimilarity.append(None if dis is None else float(dis))
        d = dis if dis is not None else next_dis
        like = (
            None
            if d is None
            else round(min(1.0, max(0.0, 1.0 - float(d) / self.config.max_dissimilarity)), 3)
        )
        st.likeness.append(like)
        rom = None
        if st.rom_joint is not None:
            j = [name for name, _, _ in ROM_JOINTS].index(st.rom_joint)
            rom = round(float(joint_ranges(self._ring.rows(a, b), (j,))[0]), 1)
            st.rom_deg.append(rom)
        self.count_ = len(spans)
        s0, s1 = st.repetitions[-1]
        self._events.append(
            RepEvent(
                s0,
                s1,
                self.count_,
                self._emitted(),
                len(self.sets_) - 1,
                round((s1 - s0) / self.fps, 3),
                rom,
                st.rom_joint,
                like,
            )
        )

    def _end_set(self, why):
        self._unliked = None
        self._skip = None
        if self._cur is not None:
            self._cur[0].end_reason = why
            self._cur = None
        self.count_ = 0

    def _frame(self, k) -> int:
        """Stream frame of decimated frame ``k`` (the filter's delay taken off)."""
        if k <= 0:
            return 0
        if self._final and k >= self._ring.k:
            return self.n_seen_
        return max(0, k * self._ring.dec - self._lag)
