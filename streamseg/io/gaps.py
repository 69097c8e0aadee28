"""Gaps in joint positions, one mechanism for files and live streams.

A *gap* of a joint is a run of frames where its position is not finite (a marker the
cameras lost, a keypoint the pose model did not see, a packet that never arrived). Each
joint's gaps are handled on their own:

* a gap of at most ``max_frames`` frames between two finite frames is filled by linear
  interpolation between them (a short occlusion: the detectors see the motion through it);
* a longer gap, or one with no finite frame before it, stays NaN: the detectors skip those
  frames (their clocks go on, so frame numbers stay the recording's own).

:class:`GapFiller` does this on a stream: it holds back a joint's NaN frames only while the
gap could still be filled (at most ``max_frames`` frames), so finite data flows through at
once and a file read whole gets exactly what a live stream of it gets. The frames that stay
NaN in the joints the features use are reported as *gaps* ``[start, end)``.

Default: 0.25 s (:data:`FILL_S`), see docs/decisions.md (Sources).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from streamseg.state import Stateful

#: Gaps up to this many seconds are filled by interpolation (the CLI's ``--gap-fill``).
FILL_S = 0.25


def fill_frames(fps: float, seconds: float = FILL_S) -> int:
    """The longest gap, in frames, that ``seconds`` fills at ``fps`` (0: none)."""
    if not (math.isfinite(seconds) and seconds >= 0):
        raise ValueError(f"gap fill {seconds!r} s is invalid: expected seconds >= 0")
    return int(math.floor(seconds * fps + 1e-9))


@dataclass(frozen=True)
class GapReport:
    """What :func:`fill_gaps` did to a recording.

    Attributes
    ----------
    gaps : list of (int, int)
        ``[start, end)`` frame ranges left NaN in the watched joints (the detectors skip them).
    filled_frames : int
        Frames in which at least one joint was filled by interpolation.
    max_frames : int
        The longest gap that was filled, in frames.
    """

    gaps: list
    filled_frames: int
    max_frames: int

    @property
    def skipped_frames(self) -> int:
        return sum(e - s for s, e in self.gaps)


class GapFiller(Stateful):
    """Fill short gaps of each joint on a stream of position packets.

    Parameters
    ----------
    n_joints : int
    max_frames : int
        Longest gap filled by interpolation (frames); 0 fills nothing.
    watch : array_like of int, optional
        Joints whose remaining NaN frames make a reported gap (default: every joint); the
        cut detector's bone end points, typically.

    Notes
    -----
    :meth:`push` returns the frames it can release: every frame before the first one that
    belongs to a gap still open and short enough to be filled. :meth:`finish` releases the
    rest. Released frames are contiguous and start where the previous release ended.
    """

    def __init__(self, n_joints: int, max_frames: int, watch=None):
        self.n_joints = int(n_joints)
        self.max_frames = int(max_frames)
        self.watch = (
            np.arange(self.n_joints)
            if watch is None
            else np.unique(np.asarray(watch, dtype=np.int64))
        )
        self._held = None  # (h, J, 3) float64 frames not yet released
        self._lost = None  # (h,) bool: the held frame never arrived (inserted as NaN)
        self._touched = None  # (h,) bool: a joint of the held frame was filled
        self.next_frame = 0  # stream frame of the first held frame (or the next one)
        self._last = np.full((self.n_joints, 3), np.nan)  # last finite released value
        self._last_frame = np.full(self.n_joints, -1, dtype=np.int64)
        self._tail = None  # the last frame passed through by _pass (all joints finite)
        self._gap_start = None  # start of a reported gap still open at the release edge
        self._gap_lost = True  # every frame of that open gap was lost (never arrived)
        self.gaps = []  # closed gaps ``(start, end, all_lost)`` not yet taken
        self.filled_frames = 0
        self.released_lost = None  # ``lost`` of the last frames released (None: none lost)

    @property
    def held(self) -> int:
        """Frames held back (waiting for a gap to close)."""
        return 0 if self._held is None else int(self._held.shape[0])

    def push(
        self, positions: np.ndarray, first_frame: int | None = None, lost: np.ndarray | None = None
    ):
        """Take frames ``first_frame ...`` of ``positions`` (n, J, 3).

        Parameters
        ----------
        positions : ndarray, shape (n, n_joints, 3)
        first_frame : int, optional
            Stream frame of ``positions[0]``; must continue the previous packet (default).
        lost : ndarray of bool, shape (n,), optional
            Frames that never arrived (NaN rows put in their place); gaps made of them only
            are marked so that whoever reported the loss need not report them again.

        Returns
        -------
        released : ndarray, shape (m, n_joints, 3), float64
            Frames ``start ... start + m - 1`` with their short gaps filled (m may be 0).
        start : int
            Stream frame of ``released[0]``.
        """
        pos = np.asarray(positions, dtype=np.float64)
        if first_frame is not None and self.held == 0:
            self.next_frame = int(first_frame)
        elif first_frame is not None and first_frame != self.next_frame + self.held:
            raise ValueError(
                f"packet at frame {first_frame} does not continue frame "
                f"{self.next_frame + self.held}"
            )
        if self._held is None and np.isfinite(pos).all():  # the common case: no copy, no scan
            return self._pass(pos, lost)
        lost = np.zeros(pos.shape[0], dtype=bool) if lost is None else np.asarray(lost, bool)
        if self._held is not None:
            pos = np.concatenate([self._held, pos])
            lost = np.concatenate([self._lost, lost])
            touched = np.concatenate([self._touched, np.zeros(len(lost) - self.held, bool)])
        else:
            pos = pos.copy()
            touched = np.zeros(pos.shape[0], dtype=bool)
        hold = self._fill(pos, touched)
        self._held = pos[hold:] if hold < pos.shape[0] else None
        self._lost = lost[hold:] if self._held is not None else None
        self._touched = touched[hold:] if self._held is not None else None
        return self._release(pos[:hold], lost[:hold], touched[:hold])

    def finish(self):
        """Release every held frame (gaps still open stay NaN); returns ``(released,
        start)`` as :meth:`push`. Any open reported gap is closed."""
        if self._held is None:
            self.released_lost = None
            out = np.zeros((0, self.n_joints, 3)), self.next_frame
        else:
            pos, lost, touched = self._held, self._lost, self._touched
            self._held = self._lost = self._touched = None
            out = self._release(pos, lost, touched)
        if self._gap_start is not None:
            self.gaps.append((self._gap_start, self.next_frame, self._gap_lost))
            self._gap_start = None
        return out

    def take_gaps(self) -> list:
        """The gaps closed since the last call, as ``(start, end, all_lost)``."""
        out, self.gaps = self.gaps, []
        return out

    def _settle(self) -> None:
        """Every joint's last finite value from the last frame :meth:`_pass` let through."""
        if self._tail is not None:
            self._last[:] = self._tail
            self._last_frame[:] = self.next_frame - 1
            self._tail = None

    def _fill(self, pos: np.ndarray, touched: np.ndarray) -> int:
        """Fill the closed short gaps of ``pos`` (in place); return how many leading frames
        can be released (the rest belong to a gap that may still be filled)."""
        self._settle()
        m = pos.shape[0]
        f0 = self.next_frame
        hold = m
        bad = ~np.isfinite(pos).all(axis=2)  # (m, J)
        for j in np.flatnonzero(bad.any(axis=0)):
            col = bad[:, j]
            edges = np.diff(np.concatenate([[False], col, [False]]).astype(np.int8))
            for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
                if a > 0:
                    prev_frame, prev = f0 + a - 1, pos[a - 1, j]
                else:
                    prev_frame, prev = int(self._last_frame[j]), self._last[j]
                if prev_frame < 0 or (f0 + b) - (prev_frame + 1) > self.max_frames:
                    continue  # no frame before it, or too long: stays NaN
                if b == m:  # open: wait for its end, while it can still be filled
                    hold = min(hold, int(a))
                    continue
                nxt_frame = f0 + b
                t = (np.arange(f0 + a, f0 + b, dtype=np.float64) - prev_frame) / float(
                    nxt_frame - prev_frame
                )
                pos[a:b, j] = prev + (pos[b, j] - prev) * t[:, None]
                touched[a:b] = True
        return hold

    def _pass(self, pos: np.ndarray, lost):
        """Release finite frames with nothing held (a live stream's every packet, mostly)."""
        start, n = self.next_frame, pos.shape[0]
        self.released_lost = lost
        if n:
            self._tail = pos[-1].copy()  # every joint's last value: set in _settle, if needed
            if self._gap_start is not None:  # the open gap ended at ``start``
                self.gaps.append((self._gap_start, start, self._gap_lost))
                self._gap_start = None
            self.next_frame = start + n
        return pos, start

    def _release(self, pos: np.ndarray, lost: np.ndarray, touched: np.ndarray):
        self._settle()
        start = self.next_frame
        n = pos.shape[0]
        self.released_lost = lost
        if n == 0:
            return pos, start
        self.filled_frames += int(np.count_nonzero(touched))
        ok = np.isfinite(pos).all(axis=2)  # (n, J)
        seen = ok.any(axis=0)
        if seen.any():
            last = n - 1 - np.argmax(ok[::-1], axis=0)  # last finite row of each joint
            js = np.flatnonzero(seen)
            self._last[js] = pos[last[js], js]
            self._last_frame[js] = start + last[js]
        self._track_gaps(~ok[:, self.watch].all(axis=1), lost, start)
        self.next_frame = start + n
        return pos, start

    def _track_gaps(self, missing: np.ndarray, lost: np.ndarray, start: int) -> None:
        """Extend / close the reported gaps with the released frames' ``missing`` flags."""
        n = missing.shape[0]
        edges = np.diff(np.concatenate([[False], missing, [False]]).astype(np.int8))
        runs = list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))
        if self._gap_start is not None:  # a gap open at ``start``: does it go on?
            if runs and runs[0][0] == 0:
                a, b = runs.pop(0)
                self._gap_lost = self._gap_lost and bool(lost[a:b].all())
                if b == n:
                    return
                end = start + int(b)
            else:
                end = start
            self.gaps.append((self._gap_start, end, self._gap_lost))
            self._gap_start = None
        for a, b in runs:
            all_lost = bool(lost[a:b].all())
            if b == n:
                self._gap_start, self._gap_lost = start + int(a), all_lost
            else:
                self.gaps.append((start + int(a), start + int(b), all_lost))


def fill_gaps(positions: np.ndarray, fps: float, seconds: float = FILL_S, watch=None):
    """Fill the short gaps of a whole recording, as a live stream of it would be filled.

    Parameters
    ----------
    positions : ndarray, shape (n_frames, n_joints, 3)
    fps : float
    seconds : float
        Longest gap filled (default :data:`FILL_S`); 0 fills nothing.
    watch : array_like of int, optional
        Joints whose remaining NaN frames count as gaps (default: all).

    Returns
    -------
    positions : ndarray of float64, shape as given (the input itself when it has no NaN)
    report : GapReport
    """
    n_joints = positions.shape[1]
    filler = GapFiller(n_joints, fill_frames(fps, seconds), watch)
    if np.isfinite(positions).all():
        return positions, GapReport([], 0, filler.max_frames)
    a, _ = filler.push(positions, 0)
    b, _ = filler.finish()
    out = a if b.shape[0] == 0 else np.concatenate([a, b])
    return out, GapReport(
        [(s, e) for s, e, _ in filler.take_gaps()], filler.filled_frames, filler.max_frames
    )
