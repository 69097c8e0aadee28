"""A pipeline step's cut events as protocol events, and the stream's recent-cut list kept in
step (the ``state`` reply's ``cuts``: withdrawn cuts leave it, confirmed ones are final).

With the two-stage detector (``LOFConfig.early_delay_s``) a cut may be ``pending``; a later
``confirm`` or ``withdraw`` event of the same frame settles it (docs/protocol.md). Every
provisional cut is then settled by a relabel (:mod:`streamseg.daemon.settle`): a ``confirm``
with its ``settled`` frame, or a ``withdraw``, both with the ``revision``; a boundary of a
relabel that no cut announced becomes a ``cut`` that is not provisional.
"""

from __future__ import annotations

import dataclasses

from streamseg import protocol
from streamseg.online.events import ConfirmEvent, WithdrawEvent

#: kinds of the cut events a pipeline step returns: a cut final when emitted, a pending cut
#: (two-stage detector), its confirmation, its withdrawal, its withdrawal before a cut nearby
CUT_KINDS = ("cut", "pending", "confirm", "withdraw", "moved")


def cut_kind(ev) -> str:
    """The :data:`CUT_KINDS` entry of a cut detector event."""
    if isinstance(ev, ConfirmEvent):
        return "confirm"
    if isinstance(ev, WithdrawEvent):
        return "moved" if ev.moved else "withdraw"
    return "pending" if ev.pending else "cut"


#: kinds of the events that settle provisional cuts (:meth:`StreamPipeline.relabelled`)
SETTLE_KINDS = ("confirmed", "rejected", "found")


def publish_cut(
    publish,
    st,
    frame: int,
    score: float,
    emitted: int,
    kind: str,
    settled: int | None = None,
    revision: int | None = None,
) -> None:
    """Publish one ``(frame, score, emitted, kind)`` cut event of stream ``st`` with
    ``publish(st, event) -> numbered event`` and update ``st.cuts``; the kinds of
    :data:`SETTLE_KINDS` carry the relabel's ``settled`` frame and its ``revision``."""
    when = st.time_of(frame)
    if kind in ("cut", "pending", "found"):
        ev = protocol.Cut(
            st.stream,
            frame,
            when,
            score,
            emitted,
            kind != "found",
            True if kind == "pending" else None,
            revision if kind == "found" else None,
        )
        st.cuts.append(publish(st, ev))
        return
    if kind == "confirm":
        publish(st, protocol.Confirm(st.stream, frame, when, score, emitted))
    elif kind == "confirmed":
        publish(st, protocol.Confirm(st.stream, frame, when, score, emitted, settled, revision))
    else:
        publish(
            st,
            protocol.Withdraw(
                st.stream,
                frame,
                when,
                emitted,
                kind == "moved",
                revision if kind == "rejected" else None,
            ),
        )
    for i in range(len(st.cuts) - 1, -1, -1):
        c = st.cuts[i]
        if c.frame == frame and (c.pending or kind in SETTLE_KINDS) and c.provisional:
            if kind == "confirm":
                st.cuts[i] = dataclasses.replace(c, pending=None)
            elif kind == "confirmed":  # settled: where the relabel puts it, no longer open
                st.cuts[i] = dataclasses.replace(
                    c,
                    frame=settled,
                    time=st.time_of(settled),
                    pending=None,
                    provisional=False,
                    revision=revision,
                )
            else:
                del st.cuts[i]
            return
