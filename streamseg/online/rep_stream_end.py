"""The end of a stream for the repetition counter: the repetition its last frames hold.

:class:`~streamseg.online.repetition.RepetitionCounter` takes :meth:`StreamEnd.finish` from
here: in a set, the last loop counts when it came back within ``end_return_ratio`` or aligns
with the last repetition; looking for a set, the same for a loop after a closed one.
"""

from __future__ import annotations

import numpy as np

from streamseg.online.rep_events import RepEvent

__all__ = ["StreamEnd"]


class StreamEnd:
    """:meth:`finish` of :class:`~streamseg.online.repetition.RepetitionCounter`."""

    def finish(self) -> list[RepEvent]:
        """The stream has ended: the repetition its last frames still hold, if any.

        In a set, the last loop counts when it came back within ``end_return_ratio`` (cut at
        its rest, at most ``pause_s / 2`` in, or at the end), or, with ``extend_edges``, when
        the frames after the last cut align with the last repetition. Looking for a set, the
        same for a loop after a closed one.
        """
        self._events = []
        if self._bridge is not None:  # the frames still waiting for a lost joint
            self._learn(self._features(None, final=True))
        flushed, self._events = self._events, []
        if self._ring.Z is None or self._ring.k < 1:
            return flushed
        self._final = True
        self._now = self.n_seen_
        cfg = self.config
        t = self._ring.k
        n = self._na[0]
        if not self._search and self._cur is not None:
            loop = self._last_loop(0, t, True)
            r = None if loop is None else self._ring.dissimilarity(self._last(), loop)
            pair = None if loop is None else self._two_in_one(loop, r)
            if pair is not None:
                self._add(*pair[0])
                loop, r = pair[1]
            if r is not None and r <= cfg.max_dissimilarity:
                self._add(loop, r)
            elif cfg.extend_edges:
                # with the set's uncounted lead-in, the piece makes one repetition the
                # counter's phase cut in two
                share = max(0.0, cfg.edge_ratio - self._lead) if self._lead else None
                piece = self._ring.edge_after(self._last(), int(self._st[0, 0]), t, share)
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
                r = self._ring.dissimilarity(prev, loop)
                self.best_dissimilarity_ = min(self.best_dissimilarity_, r)
                if r <= cfg.max_dissimilarity and self._alike_pair(prev, loop):
                    self._start_set(prev, loop, r)
                    done = True
                    break
            if not done and cfg.extend_edges:
                for e in sorted(self._cands, reverse=True):
                    prev = self._cands[e]
                    if prev is None:
                        continue
                    piece = self._ring.edge_after(prev, e, t)
                    if piece is not None and self._alike_pair(prev, piece[0], tempo=False):
                        self._start_set(prev, piece[0], piece[1])
                        done = True
                        break
            if not done and cfg.extend_edges:  # one loop and the piece before it
                for e in sorted(self._cands, reverse=True):
                    prev = self._cands[e]
                    if prev is None:
                        continue
                    piece = self._ring.edge_piece_before(prev, self._origin, 0.0, False)
                    if piece is None:
                        continue
                    if piece[2] >= cfg.edge_ratio and piece[0][2] >= cfg.amplitude_ratio * prev[2]:
                        if self._alike_pair(piece[0], prev, tempo=False):
                            self._start_set(piece[0], prev, piece[1])
                            break
                        continue
                    # too short alone: with the piece after the loop, one repetition
                    after = self._ring.edge_after(prev, e, t, cfg.edge_ratio - piece[2])
                    if after is not None and self._alike_pair(prev, after[0], tempo=False):
                        self._start_set(prev, *after)
                        break
            self._end_set("end")
        return flushed + self._events

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
            d = np.linalg.norm(self._ring.rows(s, t) - self._ring.Z[s % self._ring.C], axis=1)
            e, x = tm - s, tm - s
            while e - 1 > tM - s and d[e - 1] <= level:
                e -= 1
            while x + 1 <= t - s and d[x + 1] <= level:
                x += 1
            if x >= t - s - 1:
                cut = min(t, s + e + self._pause // 2)
            else:
                sp = np.linalg.norm(
                    self._ring.rows(s + e + 1, s + x + 1) - self._ring.rows(s + e - 1, s + x - 1),
                    axis=1,
                )
                cut = s + e + int(np.argmin(sp))
        return (s, cut, M)
