"""The repetition counter's input: frames with lost joints bridged, then pose rows.

:class:`~streamseg.online.repetition.RepetitionCounter` takes these methods from
:class:`PoseInput`: the positions of each packet go through the counter's
:class:`~streamseg.online.rep_bridge.PoseBridge` (lost joints bridged, causally, one rule live
and offline), then become pose rows (:func:`streamseg._kernels.rep_track.pose_features`, the
body size from exactly the first frames), and the frames the bridge released late are
remembered so an event's ``emitted_at`` is the frame that decided it.
"""

from __future__ import annotations

import numpy as np

from streamseg._kernels import frames_in
from streamseg._kernels import rep_track as K
from streamseg.online.rep_pose import OWN, body_scale

__all__ = ["PoseInput"]


class PoseInput:
    """The input methods of :class:`~streamseg.online.repetition.RepetitionCounter` (its
    state: ``_names``, ``_up``, ``_idx``, ``_bridge``, ``_waits``, ``_scale``, ``_pending``)."""

    @property
    def lost_joints_(self) -> list:
        """The counter's joints (canonical names) lost for longer than the bridge
        interpolates (:mod:`streamseg.online.rep_bridge`) so far: held where last seen."""
        b = self._bridge
        return [] if b is None else [K.POINTS[j] for j in b.long_lost]

    def new_lost_joints(self) -> list:
        """:attr:`lost_joints_` not returned by an earlier call (a live stream's warning)."""
        b = self._bridge
        if b is None or b.told == len(b.long_lost):
            return []
        new, b.told = b.long_lost[b.told :], len(b.long_lost)
        return [K.POINTS[j] for j in new]

    def _features(self, X, final=False):
        """Pose rows of the frames the bridge releases (None: none yet)."""
        if self._names is None:
            return X
        if self._idx is None:
            from streamseg.online.rep_bridge import PoseBridge, bridge_frames
            from streamseg.skeleton.names import POINTS, resolve

            self._idx = np.asarray(resolve(list(self._names), K.POINTS, POINTS), dtype=np.int64)
            self._upv = None
            # no pose without the pelvis, the sternum and the hips (POINTS 0-3)
            self._bridge = PoseBridge(len(K.POINTS), bridge_frames(self.fps), range(4))
        X, got = self._bridge.finish() if final else self._bridge.push(X[:, self._idx])
        if got is not None:
            self._wait(got)
        if X.shape[0] == 0 and self._scale is not None:
            return None
        if self._scale is None:  # body size from exactly the first frames: chunking-free
            self._pending.append(X)
            buf = np.concatenate(self._pending)
            if buf.shape[0] < self._init:
                return None
            self._pending = []
            self._scale = body_scale(buf[: self._init], OWN)
            X = buf
        from streamseg.skeleton.bones import up_vector

        if self._upv is None:
            self._upv = np.asarray(up_vector(self._up), dtype=np.float64)
        out = np.empty((X.shape[0], K.N_FEATURES))
        K.pose_features(frames_in(X), OWN, K.BONES, self._upv, self._scale, out)
        return out

    def _wait(self, got):
        """Remember the counter frames the bridge released late (for ``emitted_at``)."""
        first = self.n_seen_ + sum(p.shape[0] for p in self._pending)
        late = np.flatnonzero(got != first + np.arange(1, got.shape[0] + 1))
        if late.size:
            self._waits.update(zip((first + late).tolist(), got[late].tolist()))
            if len(self._waits) > 4 * self._ring.C * self._ring.dec:  # older than the ring
                old = first - self._ring.C * self._ring.dec
                self._waits = {k: v for k, v in self._waits.items() if k >= old}

    def _emitted(self) -> int:
        """Frames received when the frame deciding now (``_now - 1``) was released."""
        return self._waits.get(self._now - 1, self._now) if self._waits else self._now
