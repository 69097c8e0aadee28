"""Angular-speed columns appended to the LOF features, causally (``LOFConfig.speed_max``).

The LOF histograms of a window then hold how fast each angle moves as well as where it is:
two actions through the same poses at different speeds (walking and running, a slow and a
fast repetition) differ, and a held pose differs from motion through it.
"""

from __future__ import annotations

import numpy as np

from streamseg._kernels import speeds as _ks
from streamseg.config import LOFConfig
from streamseg.state import Stateful


class SpeedColumns(Stateful):
    """Stateful: each block of frames (n, d) in, the frames and their speeds (n, 2 d) out.

    The speed of a frame uses only frames before it (see :mod:`streamseg._kernels.speeds`),
    so feeding a stream in any blocks gives the same columns as the whole array at once.
    Memory: ``(lag + 2) * d`` floats (``lag = speed_lag_s * fps`` frames).

    Column order: the first ``d - r`` columns, their speeds, then the last ``r =
    config.root_columns`` (the root speeds) and their speeds: the checks that place and
    confirm a cut read the first ``config.check_columns(d)`` columns only.
    """

    STATE_VERSION = 2  # 2: _order always stored

    def __init__(self, config: LOFConfig, fps: float, d: int):
        lag = config.frames(fps)["speed_lag"]
        self.d = int(d)
        self.scale = float(np.pi / (config.speed_max * lag / fps))
        self._st = np.zeros(_ks.ST_SIZE, dtype=np.int64)
        self._ring = np.zeros((lag, self.d))
        self._ref = np.zeros(self.d)
        self._first = np.zeros(self.d)
        m = self.d - config.root_columns
        self._order = (
            None
            if m == self.d
            else np.r_[0:m, self.d : self.d + m, m : self.d, self.d + m : 2 * self.d]
        )

    def __call__(self, block: np.ndarray) -> np.ndarray:
        out = np.empty((block.shape[0], 2 * self.d))
        _ks.append_speeds(block, out, self._st, self._ring, self._ref, self._first, self.scale)
        return out if self._order is None else np.ascontiguousarray(out[:, self._order])

    def kernel_args(self) -> tuple:
        """``(st, ring, ref, first, scale, order)``: the arguments of
        :func:`streamseg._kernels.speeds.append_speeds` after the block and its output, and
        the column order of the result (an index into the output's columns)."""
        order = np.arange(2 * self.d) if self._order is None else self._order
        return (
            self._st,
            self._ring,
            self._ref,
            self._first,
            self.scale,
            np.asarray(order, dtype=np.int64),
        )


#: :meth:`SpeedColumns.kernel_args` of a detector without speed columns: ``ring`` with no row
NO_SPEEDS = (
    np.zeros(3, dtype=np.int64),
    np.zeros((0, 1)),
    np.zeros(1),
    np.zeros(1),
    1.0,
    np.zeros(0, dtype=np.int64),
)


def lof_columns(angles: np.ndarray, config: LOFConfig, fps: float) -> np.ndarray:
    """The columns the LOF histograms are made of for a whole array (n, d): the features,
    followed by their speeds when ``config.speed_max > 0`` (the root speeds and theirs last,
    see :class:`SpeedColumns`)."""
    a = np.ascontiguousarray(angles, dtype=np.float64)
    if config.speed_max <= 0:
        return a
    return SpeedColumns(config, fps, a.shape[1])(a)
