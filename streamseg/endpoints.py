"""ZeroMQ endpoint options shared by the daemon and its clients (transport only)."""

from __future__ import annotations

import zmq

__all__ = ["ipv6", "needs_ipv6"]


def needs_ipv6(endpoint: str) -> bool:
    """Whether ``endpoint`` names an IPv6 address in brackets: ``tcp://[::1]:5560``, or a
    connect endpoint with a source address, ``tcp://127.0.0.1;[::1]:5560`` (ZeroMQ's
    ``source;destination`` form, either side bracketed)."""
    return endpoint.startswith("tcp://[") or ";[" in endpoint


def ipv6(sock: zmq.Socket, endpoint: str) -> None:
    """Turn on ZeroMQ's IPv6 for an endpoint that :func:`needs_ipv6` (off, binding ``[::1]``
    fails with "No such device" and connecting to it never succeeds); before bind or
    connect."""
    if needs_ipv6(endpoint):
        sock.setsockopt(zmq.IPV6, 1)
