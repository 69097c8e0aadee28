"""Lost joints bridged for the repetition counter, causally: one rule live and offline.

The counter needs every frame (a causal low-pass, decimation) and a trunk in each; a capture
loses joints (a marker cluster hidden, a person out of the camera's view). Per joint, a run of
frames where it is not finite, ``[a, b)`` (``b``: the frame it is seen again), is bridged:

* a run of at most ``hold`` frames: interpolated linearly between the frames around it (from
  the first frame it is seen, when the take began without it);
* a longer run: the joint stays where it was last seen (never seen: left out, NaN, which the
  pose vector reads as a still bone: :func:`streamseg._kernels.rep_track.pose_features`);
* frames before the trunk and hips (``needed``) are all first seen are that frame's copies
  (there is no pose to read before it).

A frame is released once its every joint is decided: at once when all are finite, when a
short run closes, or ``hold`` frames into a run (it is long then). So frames wait at most
``hold`` frames (the take's frames before its first trunk excepted), only while a joint is
missing, and a joint lost for good delays nothing after its first ``hold`` frames. The rule
reads no frame more than ``hold`` ahead, so the frames released are the same however the
stream is cut into packets: the daemon's counter and ``segment --method rep`` count the same.
"""

from __future__ import annotations

import math

import numpy as np

from streamseg.state import Stateful

__all__ = ["BRIDGE_S", "PoseBridge", "bridge_frames"]

#: Longest run of frames without a joint bridged by interpolation, seconds (and the longest a
#: frame waits for it). Half a second: the delay a repetition event may have beyond its own
#: duration (benchmarks/repetitions.py, live); longer runs hold the joint where it was seen.
BRIDGE_S = 0.5


def bridge_frames(fps: float, seconds: float = BRIDGE_S) -> int:
    """The longest run bridged by interpolation at ``fps``, in frames."""
    return int(math.floor(seconds * fps + 1e-9))


class PoseBridge(Stateful):
    """Bridge lost joints of a stream of positions (module docstring).

    Parameters
    ----------
    n_joints : int
    hold : int
        Longest run of lost frames interpolated, frames (>= 0).
    needed : sequence of int
        Joints without which a frame has no pose (trunk, hips).

    Attributes
    ----------
    n_in : int
        Frames received.
    n_out : int
        Frames released.
    long_lost : list of int
        Joints that were lost longer than ``hold`` frames at some point, in the order seen.
    """

    def __init__(self, n_joints: int, hold: int, needed):
        self.n_joints = int(n_joints)
        self.hold = int(hold)
        self.needed = np.asarray(needed, dtype=np.int64)
        self.n_in = 0
        self.n_out = 0
        self.long_lost = []
        self.told = 0  # long_lost[:told] were reported (RepetitionCounter.new_lost_joints)
        self._lead = 0  # frames received before the first with every needed joint
        self._buf = np.zeros((0, self.n_joints, 3))  # frames received, not released
        self._prev = np.full((self.n_joints, 3), np.nan)  # last finite value before _buf
        self._since = np.full(self.n_joints, -1, dtype=np.int64)  # start of a run open there

    def push(self, X: np.ndarray):
        """Frames ``X`` (n, n_joints, 3) in; returns ``(released, received)``: the frames
        now decided, in order (m, n_joints, 3), and for each the number of frames received
        when it was decided (int64, (m,): its own number + 1 unless it waited), or None
        when no frame waited."""
        X = np.asarray(X, dtype=np.float64)
        n = X.shape[0]
        if n == 0:
            return X, None
        first = self.n_in
        self.n_in += n
        if self.n_out == 0 and self._buf.shape[0] == 0:
            ok = np.isfinite(X[:, self.needed]).all(axis=(1, 2))
            if not ok.any():
                self._lead += n
                return X[:0], None
            k = int(np.argmax(ok))
            lead = self._lead + k
            self._lead = 0
            X = np.concatenate([np.repeat(X[k : k + 1], lead, axis=0), X[k:]]) if lead else X
            first = self.n_in - X.shape[0]
            floor = first + lead if lead else None  # the copies were decided with that frame
        else:
            floor = None
        if self._buf.shape[0] == 0 and np.isfinite(X).all():  # nothing lost: pass through
            self._prev = X[-1].copy()
            self._since[:] = -1
            self.n_out += X.shape[0]
            if floor is None:
                return X, None
            return X, np.maximum(np.arange(first + 1, self.n_in + 1, dtype=np.int64), floor + 1)
        return self._release(X, floor, final=False)

    def finish(self):
        """The frames still waiting (the take ended: runs still open hold their joint)."""
        if self._buf.shape[0] == 0:
            return self._buf, None
        return self._release(self._buf[:0], None, final=True)

    def _release(self, X, floor, final):
        B = np.concatenate([self._buf, X]) if self._buf.shape[0] else X
        m = B.shape[0]
        b0 = self.n_out  # frame number of B[0]
        g = b0 + np.arange(m, dtype=np.int64)
        last = self.n_in - 1  # the last frame received
        bad = ~np.isfinite(B).all(axis=2)  # (m, J)
        out = B.copy()
        ready = g.copy()  # the frame whose arrival decided each frame
        if floor is not None:
            ready[: floor - b0] = floor
        H = self.hold
        for j in np.flatnonzero(bad.any(axis=0)):
            col = bad[:, j]
            edges = np.flatnonzero(np.diff(np.concatenate([[0], col.view(np.int8), [0]])))
            for a, b in zip(edges[::2], edges[1::2]):
                start = int(self._since[j]) if a == 0 and self._since[j] >= 0 else int(g[a])
                before = self._prev[j] if a == 0 else B[a - 1, j]
                closed = b < m
                end = int(g[b]) if closed else None  # the frame it is seen again
                if closed and end - start <= H:  # short: interpolated, decided at its end
                    after = B[b, j]
                    if np.isfinite(before).all():
                        w = (g[a:b] - (start - 1)) / (end - (start - 1))
                        out[a:b, j] = before + w[:, None] * (after - before)
                    else:
                        out[a:b, j] = after
                    ready[a:b] = np.maximum(ready[a:b], end)
                elif closed or final or last - start >= H:  # long: held where last seen
                    out[a:b, j] = before
                    if not final:
                        ready[a:b] = np.maximum(ready[a:b], min(start + H, last))
                    else:
                        ready[a:b] = last
                    if start + H <= (end if closed else last + 1) - 1 and j not in self.long_lost:
                        self.long_lost.append(int(j))
                else:  # may still close within hold: wait
                    ready[a:b] = np.iinfo(np.int64).max
        ready = np.maximum.accumulate(ready)
        k = int(np.searchsorted(ready, last, side="right"))
        self._keep(B, bad, k, g)
        return out[:k], ready[:k] + 1

    def _keep(self, B, bad, k, g):
        """State after releasing ``B[:k]``: the rest waits."""
        if k:
            for j in range(self.n_joints):
                seen = np.flatnonzero(~bad[:k, j])
                if seen.size:
                    self._prev[j] = B[seen[-1], j]
                    if seen[-1] == k - 1:
                        self._since[j] = -1
                        continue
                    self._since[j] = g[seen[-1] + 1]
                elif self._since[j] < 0:
                    self._since[j] = g[0]
        self._buf = B[k:]
        self.n_out += k
