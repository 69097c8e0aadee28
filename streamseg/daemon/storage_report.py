"""Failed writes and reads of the state directory, said as daemon-wide ``error`` events.

The event log and the checkpoint store count their failures in their writer threads; the
loop turns what is new since the last look into one ``error`` event per kind. The live
events go on either way, but an operator must learn that the record is not being kept.
"""

from __future__ import annotations


class StorageReport:
    """What the state directory's stores failed to do, since the last :meth:`check`.

    Parameters
    ----------
    eventlog : EventLog or None
    checkpoints : CheckpointStore or None
    error : callable
        ``error(stream, reason, message, n)``: the daemon's error events.
    """

    def __init__(self, eventlog, checkpoints, error):
        self.eventlog, self.checkpoints, self.error = eventlog, checkpoints, error
        self._said: dict = {}  # counter -> the value already reported

    def _new(self, key: str, value: int) -> int:
        n = value - self._said.get(key, 0)
        if n > 0:
            self._said[key] = value
        return n

    def check(self) -> None:
        """One ``error`` event per kind of failure new since the last call."""
        for store, reason, what in (
            (self.eventlog, "event_log", "events not logged"),
            (self.checkpoints, "checkpoint", "checkpoint writes failed"),
        ):
            n = self._new(reason, store.failed) if store is not None else 0
            if n > 0:
                self.error(
                    None,
                    reason,
                    f"{what} in {store.path} (disk full or not "
                    "writable? the daemon's log says): free space there, "
                    "or restart with another --state-dir",
                    n,
                )
        store = self.checkpoints
        n = self._new("paused", store.paused) if store is not None else 0
        if n > 0:
            free = "" if store.free_bytes is None else f" ({store.free_bytes / 1e6:.1f} MB free)"
            self.error(
                None,
                "checkpoint",
                f"checkpoint rounds paused: the disk of "
                f"{store.path.parent} is (nearly) full{free} and the event log goes "
                "first; they resume when there is room",
                n,
            )
        log_ = self.eventlog
        n = self._new("read", log_.read_failed) if log_ is not None else 0
        if n > 0:
            self.error(
                None,
                "event_log",
                f"the event log {log_.path} could not be read (a "
                "damaged file? the daemon's log says): `since` cannot answer from it; "
                "stop the daemon and move the file aside (a new log starts)",
                n,
            )
