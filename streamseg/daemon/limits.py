"""Input limits of the daemon: frame-rate range, sequence jumps, clocks, and rate limits.

Plain checks on numbers (no algorithm code): each returns a message for an ``error`` event, or
None when the input is acceptable.
"""

from __future__ import annotations

import math

MAX_CLOCK = 1e12  # |timestamp| in seconds (31,700 years): t0 + frame / fps stays finite


def fps_problem(fps: float, config) -> str | None:
    """Why an announced ``fps`` is refused, or None."""
    if not (config.min_fps <= fps <= config.max_fps):
        return (f"announce.fps={fps!r} is outside [{config.min_fps:g}, {config.max_fps:g}] Hz "
                f"(min_fps, max_fps): send the recording's frame rate")
    return None


def clock_problem(timestamp: float) -> str | None:
    """Why a packet's ``timestamp`` is refused, or None (event times must be finite JSON)."""
    if not (math.isfinite(timestamp) and abs(timestamp) <= MAX_CLOCK):
        return (f"frames.timestamp={timestamp!r} is not a finite clock within +-{MAX_CLOCK:g} s: "
                f"send the sender's clock in seconds")
    return None


def jump_problem(seq: int, expected: int, fps: float, max_seconds: float) -> str | None:
    """Why a forward ``seq`` jump is refused (beyond ``max_seconds`` of frames), or None."""
    limit = int(max_seconds * fps)
    if seq - expected > limit:
        return (f"frames.seq={seq} jumps {seq - expected} frames ahead of the expected "
                f"{expected} (more than max_seq_jump = {max_seconds:g} s = {limit} frames): "
                f"packet dropped; re-announce the stream to start it over")
    return None


class RateLimit:
    """A token bucket: :meth:`allow` is true at most ``rate`` times per second on average,
    with bursts of up to ``burst``."""

    __slots__ = ("rate", "burst", "tokens", "stamp", "refused")

    def __init__(self, rate: float, burst: float | None = None):
        self.rate = rate
        self.burst = burst if burst is not None else max(rate, 1.0)
        self.tokens = self.burst
        self.stamp = None
        self.refused = 0

    def allow(self, now: float) -> bool:
        if self.stamp is not None:
            self.tokens = min(self.burst, self.tokens + (now - self.stamp) * self.rate)
        self.stamp = now
        if self.tokens >= 1.0:
            self.tokens -= 1.0
            return True
        self.refused += 1
        return False


class IngestBudget:
    """The ingest byte budget (``ingest_bytes``) turned into ZeroMQ's message bound.

    ZeroMQ bounds a socket's queue in messages (``RCVHWM``, per connection), not bytes: 2,000
    small packets are a few MB, 2,000 packets of 10 MB are 20 GB. The thread that reads the
    ingest socket reports the largest message of each drain with its sender; while a sender's
    messages are large (within :attr:`WINDOW` s), ``RCVHWM`` is lowered so that ZeroMQ holds
    at most half the budget of such messages over all those senders; a quarter bounds what
    one drain (or the receiver's queue) holds. Senders then wait (backpressure), as they do
    when the queue of small packets is full.

    Parameters
    ----------
    budget : int
        Bytes (``ingest_bytes``).
    hwm : int
        The configured message bound (``ingest_hwm``), used while no message is large.
    """

    WINDOW = 2.0  # s a sender's large message keeps the bound lowered
    # libzmq 4.3.5 can stall a connection whose RCVHWM is lowered while it is open with a
    # ZAP handler (measured: the sender's next messages never arrive) at 3 with one sender and
    # at 4 with eight; none seen at 8 (1, 8 and 16 senders of 8.9 MB packets): never below 8
    MIN_HWM = 8

    def __init__(self, budget: int, hwm: int):
        self.share = budget // 2
        self.drain_bytes = budget // 4
        self.max_hwm = hwm
        self.hwm = hwm
        # messages at least this large lower the bound below the configured one
        self.threshold = max(1, self.share // hwm)
        self.senders: dict = {}  # sender -> (its largest recent large message, when)

    def observe(self, size: int, sender, now: float) -> int | None:
        """Take a drain's largest message (bytes) and its sender; returns the new ``RCVHWM``
        to set when it changes, else None."""
        s = self.senders
        if size >= self.threshold:
            old = s.get(sender)
            if old is None or size >= old[0] or now - old[1] > self.WINDOW:
                s[sender] = (size, now)
        for k in [k for k, (_, t) in s.items() if now - t > self.WINDOW]:
            del s[k]
        total = sum(v[0] for v in s.values())
        hwm = max(min(self.MIN_HWM, self.max_hwm), min(self.max_hwm, self.share // total)) \
            if total else self.max_hwm
        if hwm == self.hwm:
            return None
        self.hwm = hwm
        return hwm
