"""Command lines the tests run again and again, spelt once: ``streamseg`` as a child process,
``serve``'s sockets on free loopback ports, ``listen`` against a daemon's endpoints."""

from __future__ import annotations

import sys

#: ``streamseg`` in a child process, run by this interpreter
STREAMSEG = (sys.executable, "-m", "streamseg.cli")

#: the daemon's three sockets on free loopback ports (``serve`` prints the ones it got)
FREE_PORTS = tuple(
    w for flag in ("--ingest", "--publish", "--control") for w in (flag, "tcp://127.0.0.1:0")
)


def listen_to(ep: dict) -> list:
    """``listen --from PUBLISH --control CONTROL`` of the daemon at ``ep``; the test adds the
    rest (``--stream``, ``--since``, ...)."""
    return ["listen", "--from", ep["publish"], "--control", ep["control"]]
