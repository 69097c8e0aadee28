"""The streaming cut detector's kernel events: the arrays a kernel call writes them into and
the event objects (:mod:`streamseg.online.events`) they become.

The kernels (:mod:`streamseg._kernels.lof_stream`) write each event as one row of five
arrays: the cut frame, the score (LOF), the frame index at emission, the kind
(``KIND_*`` of :mod:`streamseg._kernels.lof_decide`) and the decided window's sequence
number.
"""

from __future__ import annotations

import numpy as np

from streamseg._kernels import lof_decide as _kd
from streamseg.online.events import ConfirmEvent, CutEvent, WithdrawEvent


def event_room(windows: int, early: bool, pending: int) -> int:
    """Rows for the events of ``windows`` decided windows: one each; with two stages
    (``early``) up to three each (a withdraw, a cut, a pending cut) plus one more, and each of
    the ``pending`` early cuts withdrawn."""
    return windows if not early else 4 * windows + pending


def new_event_arrays(rows: int) -> tuple:
    """Empty event arrays of ``rows`` rows: ``(frame, score, emitted_at, kind, window)``."""
    return (
        np.empty(rows, dtype=np.int64),
        np.empty(rows),
        np.empty(rows, dtype=np.int64),
        np.empty(rows, dtype=np.int64),
        np.empty(rows, dtype=np.int64),
    )


def kernel_events(n: int, ev: tuple) -> list:
    """The first ``n`` rows of the event arrays ``ev`` as :class:`CutEvent` (pending or
    final), :class:`ConfirmEvent` and :class:`WithdrawEvent`, in the order written."""
    ev_f, ev_s, ev_e, ev_k = ev[:4]
    out = []
    for i in range(n):
        f, k, e = int(ev_f[i]), int(ev_k[i]), int(ev_e[i])
        if k == _kd.KIND_CUT or k == _kd.KIND_PENDING:
            out.append(CutEvent(f, float(ev_s[i]), e, pending=k == _kd.KIND_PENDING))
        elif k == _kd.KIND_CONFIRM:
            out.append(ConfirmEvent(f, float(ev_s[i]), e))
        else:
            out.append(WithdrawEvent(f, e, moved=k == _kd.KIND_MOVED))
    return out
