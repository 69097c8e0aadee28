"""Settling a stream's provisional cuts with its relabels (docs/protocol.md, Settled cuts).

Every provisional cut makes a relabel of the frames around it due soon: ``settle_s`` seconds
after the cut (at once when the detector decided it later than that), over the window from
``focus_s`` seconds before the oldest open cut to the newest frame. A relabel settles every
open cut it holds with at least ``settle_s`` seconds of frames after it (every cut it holds,
for the stream's final relabel):

- a boundary between two actions of the relabel within ``radius`` frames of the cut: the
  cut is confirmed, at its own frame (``settled``: the detector places a cut more precisely
  than the relabel, whose boundaries move to a live cut within half that radius anyway);
- none: the cut is withdrawn;
- a cut older than the window's settled part (it left the relabel history unsettled, e.g.
  while relabels lagged): it stands, confirmed at its own frame.

A boundary of the relabel that is settled in the same sense, that the previous relabel had
too (within ``radius / 2``; any boundary of the final relabel) and that no cut explains (none
within ``radius``, confirmed or open) is announced as a cut that is not provisional. A settled
frame is never revisited; later revisions still supersede what they cover for a consumer that
applies them.

The state is plain (lists of ints and floats), so checkpoints carry it as they are.
"""

from __future__ import annotations

import bisect

from streamseg.state import Stateful

AGREE = 2  # consecutive relabels that must hold a boundary before it is announced
SETTLED_KEPT = 256  # settled frames kept per stream (an announced boundary is not repeated)


class Settlement(Stateful):
    """One stream's open provisional cuts and the focused relabel they make due.

    Parameters
    ----------
    fps : float
        The stream's frame rate.
    settle_s : float
        Seconds of frames a relabel needs after a cut to settle it.
    focus_s : float
        Seconds before the oldest open cut a focused relabel's window starts.
    radius : int
        Frames within which a relabel boundary confirms a cut.
    """

    __slots__ = ("settle", "focus", "radius", "open", "settled", "due_at", "last")

    def __init__(self, fps: float, settle_s: float, focus_s: float, radius: int):
        self.settle = int(round(settle_s * fps))
        self.focus = int(round(focus_s * fps))
        self.radius = int(radius)
        self.open = []  # [frame, score, emitted_at] of provisional cuts not settled, by frame
        self.settled = []  # sorted frames settled (confirmed there, or announced)
        self.due_at = -1  # stream frame from which a focused relabel is due (-1: none)
        self.last = []  # boundaries of the previous AGREE - 1 relabels, newest last

    # --- the detector's events ----------------------------------------------------------
    def add(self, frame: int, score: float, emitted: int) -> None:
        """A provisional cut was published: open until a relabel settles it."""
        bisect.insort(self.open, [int(frame), float(score), int(emitted)])
        due = max(int(frame) + self.settle, int(emitted))
        self.due_at = due if self.due_at < 0 else min(self.due_at, due)

    def drop(self, frame: int) -> None:
        """The detector withdrew its pending cut at ``frame``: nothing left to settle."""
        self.open = [c for c in self.open if c[0] != frame]
        if not self.open:
            self.due_at = -1

    # --- scheduling -----------------------------------------------------------------------
    def due(self, next_frame: int) -> bool:
        """Whether a focused relabel is due once frames up to ``next_frame`` have come."""
        return 0 <= self.due_at <= next_frame

    def window_start(self) -> int:
        """First frame of the focused relabel's window (the oldest open cut - focus)."""
        return self.open[0][0] - self.focus if self.open else 0

    def taken(self) -> None:
        """A relabel's snapshot was taken: the focus is served (its result settles)."""
        self.due_at = -1

    # --- a relabel's result -----------------------------------------------------------------
    def apply(
        self, segments, start: int, end: int, final: bool, now: int, first_frame: int = 0
    ) -> list:
        """The cut events that settle what the relabel ``segments`` (``(start, end, label)``
        over stream frames ``[start, end)``) can settle, published at stream frame ``now``.

        Returns
        -------
        list of (frame, score, emitted_at, kind, settled)
            ``kind`` ``"confirmed"`` (``settled``: the relabel's frame of the boundary),
            ``"rejected"`` (withdrawn) or ``"found"`` (a boundary announced as a cut).
        """
        bounds = [int(b[0]) for a, b in zip(segments[:-1], segments[1:]) if a[2] != b[2]]
        # the window's first frames have no context before them, unless the stream starts there
        lo = start if start <= first_frame else start + self.settle
        hi = end if final else end - self.settle
        out, keep, used = [], [], set()
        for frame, score, emitted in self.open:
            if frame < lo:  # older than what this relabel or any later one holds: it stands
                out.append((frame, score, now, "confirmed", frame))
                self._settled(frame)
            elif frame >= hi:  # too new: a later relabel settles it
                keep.append([frame, score, emitted])
            else:
                near = [b for b in bounds if abs(b - frame) <= self.radius and b not in used]
                if near:
                    # the relabel decides that a boundary is there, the detector where: its
                    # frame is the more precise (the relabel's boundaries move to a live cut
                    # within half the radius; one further off is HACA's guess)
                    used.add(min(near, key=lambda x: (abs(x - frame), x)))
                    out.append((frame, score, now, "confirmed", frame))
                    self._settled(frame)
                else:
                    out.append((frame, score, now, "rejected", None))
        last = self.last
        self.last = (last + [bounds])[-(AGREE - 1) :] if AGREE > 1 else []
        for b in bounds:
            if b in used or not lo <= b < hi:
                continue
            if self._near_settled(b) or any(abs(c[0] - b) <= self.radius for c in keep):
                continue
            # settled: the previous AGREE - 1 relabels had it too (HACA's boundaries inside an
            # action come and go between revisions), or this is the stream's last relabel
            if not final and (
                len(last) < AGREE - 1
                or not all(any(abs(x - b) <= self.radius // 2 for x in prev) for prev in last)
            ):
                continue
            out.append((b, 0.0, now, "found", b))
            self._settled(b)
        self.open = keep
        self.due_at = min((max(f + self.settle, e) for f, _, e in keep), default=-1)
        return out

    def _near_settled(self, b: int) -> bool:
        i = bisect.bisect_left(self.settled, b - self.radius)
        return i < len(self.settled) and self.settled[i] <= b + self.radius

    def _settled(self, b: int) -> None:
        bisect.insort(self.settled, int(b))
        if len(self.settled) > SETTLED_KEPT:
            del self.settled[0]
