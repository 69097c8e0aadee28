"""numba kernels, private: the validating Python APIs of :mod:`streamseg.online` and
:mod:`streamseg.offline` call them."""

from __future__ import annotations

import numpy as np


def frames_in(a) -> np.ndarray:
    """``a`` as a C-contiguous float64 array the kernel only reads, always read-only.

    numba compiles a kernel apart for a read-only argument: a decoded packet is read-only, a
    packet the gap filler joined or a counter's selection of frames is not. One type means
    one compiled version, the one warmed at start, and never a compile in the daemon's loop.
    """
    a = np.ascontiguousarray(a, dtype=np.float64)
    if a.flags.writeable:
        a = a.view()
        a.flags.writeable = False
    return a
