"""What the daemon remembers of streams that closed.

A client that joins after a stream ended (the view beside a daemon, ``listen`` with
``--control``) can still ask for its last state; and for a while the heartbeats still carry
its last event number, so a subscriber that lost the stream's tail (``closed`` included)
learns that it did from any of them.
"""

from __future__ import annotations

import collections
import time

KEPT = 1000  # states of closed streams kept for late joiners
# seconds the heartbeats still carry a closed stream's last event number; KEPT ids at most
LAST_SEQ_S = 30.0


class ClosedStreams:
    """The last states of the newest :data:`KEPT` closed streams, and which ids closed in
    the last :data:`LAST_SEQ_S` seconds."""

    def __init__(self):
        self.states: collections.OrderedDict = collections.OrderedDict()  # id -> state
        self._recent: collections.OrderedDict = collections.OrderedDict()  # id -> until when

    def add(self, stream: str, state: dict, reason: str) -> None:
        """``stream`` closed for ``reason`` with ``state`` (its control ``state`` reply)."""
        self._recent[stream] = time.monotonic() + LAST_SEQ_S
        self._recent.move_to_end(stream)
        self.states[stream] = {**state, "closed": reason}
        self.states.move_to_end(stream)
        while len(self.states) > KEPT:
            self.states.popitem(last=False)

    def get(self, stream: str) -> dict | None:
        return self.states.get(stream)

    def listing(self, open_ids) -> list:
        """``{stream, closed, frame}`` of each kept stream not open again, oldest first."""
        return [
            {"stream": s, "closed": cs.get("closed"), "frame": cs.get("frame")}
            for s, cs in self.states.items()
            if s not in open_ids
        ]

    def recent(self, now: float) -> list:
        """The ids closed in the last :data:`LAST_SEQ_S` seconds (at ``now``, monotonic)."""
        gone = self._recent
        while gone and (next(iter(gone.values())) < now or len(gone) > KEPT):
            gone.popitem(last=False)
        return list(gone)
