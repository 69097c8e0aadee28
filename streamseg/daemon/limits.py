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
        return (
            f"announce.fps={fps!r} is outside [{config.min_fps:g}, {config.max_fps:g}] Hz "
            f"(min_fps, max_fps): send the recording's frame rate"
        )
    return None


def clock_problem(timestamp: float) -> str | None:
    """Why a packet's ``timestamp`` is refused, or None (event times must be finite JSON)."""
    if not (math.isfinite(timestamp) and abs(timestamp) <= MAX_CLOCK):
        return (
            f"frames.timestamp={timestamp!r} is not a finite clock within +-{MAX_CLOCK:g} s: "
            f"send the sender's clock in seconds"
        )
    return None


def jump_problem(seq: int, expected: int, fps: float, max_seconds: float) -> str | None:
    """Why a forward ``seq`` jump is refused (beyond ``max_seconds`` of frames), or None."""
    limit = int(max_seconds * fps)
    if seq - expected > limit:
        return (
            f"frames.seq={seq} jumps {seq - expected} frames ahead of the expected "
            f"{expected} (more than max_seq_jump = {max_seconds:g} s = {limit} frames): "
            f"packet dropped; re-announce the stream to start it over"
        )
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
