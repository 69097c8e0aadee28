"""A pipeline step's cut events as protocol events, and the stream's recent-cut list kept in
step (the ``state`` reply's ``cuts``: withdrawn cuts leave it, confirmed ones are final).

With the two-stage detector (``LOFConfig.early_delay_s``) a cut may be ``pending``; a later
``confirm`` or ``withdraw`` event of the same frame settles it (docs/protocol.md).
"""

from __future__ import annotations

import dataclasses

from streamseg import protocol


def publish_cut(publish, st, frame: int, score: float, emitted: int, kind: str) -> None:
    """Publish one ``(frame, score, emitted, kind)`` cut event of stream ``st`` with
    ``publish(st, event) -> numbered event`` and update ``st.cuts``."""
    when = st.time_of(frame)
    if kind in ("cut", "pending"):
        ev = protocol.Cut(st.stream, frame, when, score, emitted, True,
                          True if kind == "pending" else None)
        st.cuts.append(publish(st, ev))
        return
    if kind == "confirm":
        publish(st, protocol.Confirm(st.stream, frame, when, score, emitted))
    else:
        publish(st, protocol.Withdraw(st.stream, frame, when, emitted, kind == "moved"))
    for i in range(len(st.cuts) - 1, -1, -1):
        c = st.cuts[i]
        if c.frame == frame and c.pending:
            if kind == "confirm":
                st.cuts[i] = dataclasses.replace(c, pending=None)
            else:
                del st.cuts[i]
            return
