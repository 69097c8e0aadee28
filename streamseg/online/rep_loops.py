"""The repetition counter's recent poses, and how two loops among them compare.

The counter (:mod:`streamseg.online.repetition`) low-passes its pose rows causally and keeps
every ``dec``-th (about ``rate_hz``) in a ring of ``buffer_s``, with the speed from one kept
row to the next. A loop is a span of kept frames with its amplitude, ``(start, end,
amplitude)``. Loops are compared by their moving frames only, so a rest inside one is no part
of its duration nor of its shape: DTW over resampled rows, per unit of amplitude.
"""

from __future__ import annotations

import numpy as np

from streamseg._kernels import rep_track as K
from streamseg.config import RepetitionConfig
from streamseg.state import Stateful

__all__ = ["PoseRing", "cutoff_hz"]


def cutoff_hz(config: RepetitionConfig, fps: float) -> float:
    """The low-pass cut-off for a stream at ``fps``: ``lowpass_low_rate_hz`` at
    ``low_rate_fps`` or less (Kinect, cameras: markerless, noisier), else ``lowpass_hz``."""
    return config.lowpass_low_rate_hz if fps <= config.low_rate_fps else config.lowpass_hz


class PoseRing(Stateful):
    """The low-passed, decimated pose rows of the last ``buffer_s`` and their speeds.

    Parameters
    ----------
    config : RepetitionConfig
    fps : float
        The stream's frame rate.

    Attributes
    ----------
    dec : int
        Stream frames per kept frame: kept frame ``k`` is stream frame ``k * dec``.
    C : int
        Rows of the ring; kept frame ``k`` is row ``k % C``.
    Z : ndarray, shape (C, d), or None
        Low-passed pose rows (None until the first frame).
    SP : ndarray, shape (C,)
        Distance of each kept row from the one before (0 for the first).
    k : int
        Newest kept frame (-1: none yet).
    """

    def __init__(self, config: RepetitionConfig, fps: float):
        from streamseg.online.lowpass import butter2_sos

        self.config = cfg = config
        self.dec = max(1, int(round(fps / cfg.rate_hz)))
        rate = fps / self.dec
        self.C = int(round(cfg.buffer_s * rate)) + 2
        self.cutoff = cutoff_hz(cfg, fps)
        self._sos = butter2_sos(min(self.cutoff, 0.45 * fps), fps)
        self._state = None
        self.Z = None
        self.SP = np.zeros(self.C)
        self.k = -1

    def push(self, F, first: int) -> None:
        """Pose rows ``F`` (n, d) of stream frames ``first`` on: low-passed, every ``dec``-th
        kept."""
        if self._state is None:
            from streamseg.online.lowpass import sos_initial_state

            # start at rest on the first frame (no transient from zero)
            self._state = sos_initial_state(self._sos)[:, :, None] * F[0][None, None, :]
            self.Z = np.zeros((self.C, F.shape[1]))
        Y = np.empty_like(F)
        K.sos_filter(F, self._sos, self._state, Y)
        # kept frames: stream frames 0, dec, 2 dec, ...
        for f in range((-first) % self.dec, F.shape[0], self.dec):
            k = (first + f) // self.dec
            row = k % self.C
            self.Z[row] = Y[f]
            self.SP[row] = (
                0.0 if k == 0 else np.sqrt(np.sum((Y[f] - self.Z[(k - 1) % self.C]) ** 2))
            )
            self.k = k

    # --- comparing loops -----------------------------------------------------------------

    def rows(self, a, b):
        """Kept rows of frames ``a .. b`` (both included)."""
        idx = np.arange(a, b + 1) % self.C
        return self.Z[idx]

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
        moving = np.flatnonzero(v > self.config.still_ratio * (v.max() if vmax is None else vmax))
        if moving.size < 2:
            return idx
        keep = np.zeros(idx.size, bool)
        keep[moving] = True
        keep[np.maximum(moving - 1, 0)] = True  # speed u is the step from u - 1 to u
        keep[0] = keep[-1] = True
        return idx[keep]

    def _speeds(self, a, b):
        v = self.SP[np.arange(a, b + 1) % self.C]
        return np.convolve(v, np.ones(3) / 3, mode="same")

    def _vmax(self, p) -> float:
        return float(self._speeds(p[0], p[1]).max())

    def length(self, p) -> int:
        """Loop ``p``'s moving duration (decimated frames)."""
        return self._moving(p).size - 1

    def _mrows(self, p):
        return self.Z[self._moving(p) % self.C]

    def _resampled(self, p):
        A = self._mrows(p)
        L = min(self.config.resample, A.shape[0])
        x = np.linspace(0.0, A.shape[0] - 1.0, L)
        i = np.floor(x).astype(np.int64)
        j = np.minimum(i + 1, A.shape[0] - 1)
        w = (x - i)[:, None]
        return A[i] * (1.0 - w) + A[j] * w

    def dissimilarity(self, p, q) -> float:
        """DTW distance of loops ``p`` and ``q`` ((start, end, amplitude)) / amplitude, their
        moving frames compared (a rest inside either is left out)."""
        cost = K.dtw_mean(self._resampled(p), self._resampled(q))
        return float(cost / max(0.5 * (p[2] + q[2]), 1e-12))

    def spread(self, p, q) -> bool:
        """The larger loop spans ``spread_ratio`` of the range of both; the smaller is at
        least ``amplitude_ratio`` of it and moves at least 1 / ``start_tempo_ratio`` as long."""
        return not self.spread_fault(p, q)

    def spread_fault(self, p, q, tempo=True) -> str:
        """Which test of :meth:`spread` loops ``p`` and ``q`` fail: "tempo" (not tested
        unless ``tempo``), "span", "amplitude", or "" (none)."""
        cfg = self.config
        da, db = self.length(p), self.length(q)
        if tempo and max(da, db) > cfg.start_tempo_ratio * min(da, db):
            return "tempo"
        W = self.rows(p[0], q[1])
        i = int(np.argmax(np.linalg.norm(W - W[0], axis=1)))
        span = float(np.linalg.norm(W - W[i], axis=1).max())
        big, small = max(p[2], q[2]), min(p[2], q[2])
        if big < cfg.spread_ratio * span:
            return "span"
        return "" if small >= cfg.amplitude_ratio * big else "amplitude"

    def split(self, p):
        """Loop ``p`` cut in two where, in its middle half, the pose comes closest back to
        its start's: ((start, u, amplitude), (u, end, amplitude)) (a loop that did not close
        at a repetition's end because the pose came back a little too far from the anchor's)."""
        a, b = p[0], p[1]
        W = self.rows(a, b)
        n = W.shape[0]
        lo, hi = n // 4, n - n // 4
        if hi - lo < 2:
            return None
        d0 = np.linalg.norm(W - W[0], axis=1)
        u = lo + int(np.argmin(d0[lo:hi]))
        first = (a, a + u, float(d0[: u + 1].max()))
        second = (a + u, b, float(np.linalg.norm(W[u:] - W[u], axis=1).max()))
        return first, second

    def _oldest(self) -> int:
        return max(0, self.k - self.C + 1)

    def edge_before(self, first, origin, share=None):
        """(piece, dissimilarity) before loop ``first``, from frame ``origin`` at the earliest,
        that aligns with it and moves at least ``share`` (default ``edge_ratio``) as long, or
        None."""
        got = self.edge_piece_before(first, origin, share)
        return None if got is None else got[:2]

    def edge_piece_before(self, first, origin, share=None, amplitude=True):
        """(piece, dissimilarity, share) as :meth:`edge_before`, with the share of ``first``'s
        moving frames the piece's aligned part moves (``amplitude`` False: the piece is not
        held to the amplitude test)."""
        a, b = first[0], first[1]
        L = self.length(first)
        need = (self.config.edge_ratio if share is None else share) * L
        lo = max(origin, a - 2 * (b - a), self._oldest())
        idx = self._moving((lo, a), self._vmax(first))
        if idx.size - 1 < max(need, 1):
            return None
        S = self.Z[idx % self.C]
        cost, j = K.edge_dtw(self._mrows(first), S)
        amp = float(np.linalg.norm(S[j:] - S[-1], axis=1).max())
        piece = (int(idx[j]), a, amp)
        return self._edge_ok(piece, first, cost, L, idx.size - 1 - int(j), need, amplitude)

    def edge_after(self, last, a, t, share=None):
        """(piece, dissimilarity) after loop ``last`` from frame ``a`` to at most ``t`` that
        aligns with it and moves at least ``share`` (default ``edge_ratio``) as long, or
        None."""
        L = self.length(last)
        need = (self.config.edge_ratio if share is None else share) * L
        idx = self._moving((a, min(t, a + 2 * (last[1] - last[0]))), self._vmax(last))
        if idx.size - 1 < max(need, 1):
            return None
        S = self.Z[idx % self.C]
        cost, j = K.edge_dtw(self._mrows(last)[::-1].copy(), S[::-1].copy())
        end = S.shape[0] - 1 - int(j)
        amp = float(np.linalg.norm(S[: end + 1] - S[0], axis=1).max())
        got = self._edge_ok((a, int(idx[end]), amp), last, cost, L, end, need)
        return None if got is None else got[:2]

    def _edge_ok(self, piece, ref, cost, L, n, need, amplitude=True):
        cfg = self.config
        if n < max(need, 1) or (amplitude and piece[2] < cfg.amplitude_ratio * ref[2]):
            return None
        r = float(cost / max(0.5 * (piece[2] + ref[2]), 1e-12))
        return (piece, r, n / max(L, 1)) if r <= cfg.max_dissimilarity else None
