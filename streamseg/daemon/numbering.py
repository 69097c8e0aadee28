"""Sequence numbers of the published events, per stream id, logged with each event."""

from __future__ import annotations

import collections
import dataclasses

from streamseg import protocol
from streamseg.daemon.state_files import LogReadError


class Numbering:
    """Gives each published event its stream's next sequence number and logs it.

    Numbers are per stream id (``*`` for daemon-wide events), start at 1 and continue over
    re-announcements and, with an event log, over restarts. ``stats`` heartbeats are not
    numbered (each supersedes the last). Counters of ids without an open stream (e.g.
    ``unknown_stream`` errors) are kept for the last ``MAX_IDS`` ids; with a log an evicted
    counter is read back from it.
    """

    MAX_IDS = 100_000

    def __init__(self, eventlog):  # an EventLog, or None (not imported: no import circle)
        self.log = eventlog
        self.last: collections.OrderedDict = collections.OrderedDict()

    def current(self, key: str) -> int:
        """The last number given to ``key`` (0: none yet)."""
        n = self.last.get(key)
        if n is None:
            try:
                n = self.log.last_seq(key) if self.log is not None else 0
            except LogReadError:  # counted by the log and reported: go on from memory
                n = 0
            if len(self.last) >= self.MAX_IDS:
                self.last.popitem(last=False)
            self.last[key] = n
        else:
            self.last.move_to_end(key)
        return n

    def next(self, key: str) -> int:
        n = self.current(key) + 1
        self.last[key] = n
        return n

    def encode(self, ev):
        """``(numbered event, [topic, body])``; ``stats`` go out unnumbered and unlogged. With
        a log the frames are queued with the row, for :meth:`EventLog.committed`."""
        if ev.type == "stats":
            return ev, protocol.encode(ev)
        key = ev.stream if ev.stream is not None else protocol.DAEMON_WIDE
        n = self.next(key)
        ev = dataclasses.replace(ev, seq=n)
        parts = protocol.encode(ev)
        if self.log is not None:
            self.log.append(key, n, ev.type, parts[1], parts)
        return ev, parts
