"""Waiting in tests on what the system under test says, never on the clock.

A test waits for a condition it reads from the real parts (a control reply, the event log
file, a counter of a running object, a file a process writes): :func:`wait_until` polls it.
Its ``timeout`` bounds a wait that would otherwise hang when the condition never comes; it is
never a duration the test relies on (a slow machine only makes the wait longer).
"""

from __future__ import annotations

import time

#: how often a condition is read again; reads are cheap (a loopback request, a SELECT)
INTERVAL = 0.01


def wait_until(check, what: str, timeout: float = 60.0, interval: float = INTERVAL):
    """Call ``check()`` until it returns a true value, and return that value.

    Parameters
    ----------
    check : callable
        No arguments; reads the condition (e.g. ``lambda: request(ep, "state", ...)``).
    what : str
        The condition in words, for the failure message.
    timeout : float
        Seconds after which the test fails (a bound, not a timing).
    interval : float
        Seconds between two reads.

    Raises
    ------
    AssertionError
        ``check`` never returned a true value in ``timeout`` seconds.
    """
    deadline = time.monotonic() + timeout
    while not (value := check()):
        if time.monotonic() > deadline:
            raise AssertionError(f"never: {what} (waited {timeout:g} s)")
        time.sleep(interval)
    return value
