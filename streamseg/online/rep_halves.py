"""Repetitions made of two loops: a movement whose two sub-movements pass the same pose.

A hurdle step's leg goes up over the hurdle and comes back down: from a pose passed on the
way up and again on the way down, the pose leaves and comes back twice per repetition, so
the counter's loops are its halves (leg up, leg down), alike enough (0.48-0.59 on Kinect) to
start a set and be counted one by one. What tells them apart is the loop after: it is like
the loop two back, not like the one before it.

So a set's first two loops that are only moderately alike (at least half of
``max_dissimilarity``) are held, not counted, until the next loop closes
(:meth:`TwoLoops._hold`). If that loop is under ``every_other_ratio`` as unlike the first as
it is unlike the second, the repetition is two loops: the held pair is the first repetition,
and the set starts when the next two loops together are like it; from then on every
repetition is two loops, the first waiting for the second. Otherwise the held pair starts the
set as it would have, one loop later (the first two events come later; the count is the
same). :class:`~streamseg.online.repetition.RepetitionCounter` takes this from here.
"""

from __future__ import annotations

from streamseg._kernels import rep_track as K

__all__ = ["TwoLoops"]


class TwoLoops:
    """The held start and the two-loop repetitions of
    :class:`~streamseg.online.repetition.RepetitionCounter`."""

    def _holds(self, r) -> bool:
        """Whether a set's first pair, alike at ``r``, waits for the next loop."""
        cfg = self.config
        return bool(cfg.every_other_ratio) and r >= 0.5 * cfg.max_dissimilarity

    def _hold(self, prev, loop, r, t):
        """Hold the pair ``prev``, ``loop`` (alike at ``r``); follow the loop after it."""
        self._held = [prev, loop, r, None, dict(self._cands)]
        self._track_from(loop[1], t)

    def _held_stats(self):
        """(amplitudes, spans) the held loops give the tracker in place of a set's."""
        loops = [lp for lp in self._held[:2]] + ([self._held[3]] if self._held[3] else [])
        return [lp[2] for lp in loops], [(lp[0], lp[1]) for lp in loops]

    def _on_held(self, loop, t):
        """The next loop while a pair is held: decide what the pair was."""
        prev, first, r, half, _ = self._held
        s, kind, cut, M = loop
        ring, cfg = self._ring, self.config
        if kind != K.TIMEOUT:
            new = (s, cut, M)
            if half is None:
                r1 = ring.dissimilarity(first, new)
                if (
                    kind == K.CLOSE
                    and r1 >= 0.5 * cfg.max_dissimilarity
                    and ring.dissimilarity(prev, new) < cfg.every_other_ratio * r1
                ):
                    self._held[3] = new  # every other loop alike: wait for its second half
                    self._track_from(cut, t)
                    return
            else:
                A = (prev[0], first[1], max(prev[2], first[2]))
                B = (half[0], cut, max(half[2], M))
                rB = ring.dissimilarity(A, B)
                if rB <= cfg.max_dissimilarity:
                    self._held = None
                    self._start_set(A, B, rB)
                    self._pair = True
                    if kind == K.PAUSE:
                        self._end_set("pause")
                        self._search_from(cut)
                    else:
                        self._track_from(cut, t)
                    return
        self._release()
        if half is not None:  # the loop after the pair, taken as a repetition, then again
            self._on_track((half[0], K.CLOSE, half[1], half[2]), t)
            if not self._search:
                self._pos = half[1]
                self._set_anchors([half[1]], half[1])
            return
        self._on_track(loop, t)

    def _held_end(self, t) -> bool:
        """At the stream's end, a held pair whose next loop showed two loops a repetition:
        the set is the pair and the frames from that loop on when they align with it."""
        prev, first, _, half, _ = self._held
        if half is None:
            return False
        A = (prev[0], first[1], max(prev[2], first[2]))
        piece = self._ring.edge_after(A, half[0], t)
        if piece is None:
            return False
        self._held = None
        self._start_set(A, *piece)
        self._end_set("end")
        return True

    def _release(self):
        """The held pair starts the set as it would have without holding."""
        prev, first, r, _, cands = self._held
        self._held = None
        self._cands = cands
        self._start_set(prev, first, r)
        self._cands = {}

    def _pair_loop(self, new, kind, t):
        """In a set of two-loop repetitions: None while ``new`` is the first half (it waits),
        else the whole repetition it closes."""
        if self._half is None and kind == K.CLOSE:
            self._half = new
            self._track_from(new[1], t)
            return None
        if self._half is not None:
            h, self._half = self._half, None
            return (h[0], new[1], max(h[2], new[2]))
        return new
