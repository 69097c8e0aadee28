"""Subscriptions known to be live: a SUB socket (:func:`subscriber`), then the ``hello``
handshake that proves the daemon's publisher reaches it (:func:`handshake`)."""

from __future__ import annotations

import time

import zmq

from streamseg import protocol
from streamseg.client.control import request
from streamseg.endpoints import ipv6


def subscriber(endpoint: str, stream=None, kind=None, ctx=None, curve=None, monitor=None):
    """A SUB socket connected to ``endpoint`` with the prefixes selecting stream/type.

    ``monitor``: monitor events (e.g. :attr:`Refusal.EVENTS`) to watch from before the
    connection starts; then returns ``(sock, monitor socket)``.
    """
    ctx = ctx or zmq.Context.instance()
    sock = ctx.socket(zmq.SUB)
    if curve is not None:
        curve.apply(sock)
    sock.setsockopt(zmq.LINGER, 0)
    sock.setsockopt(zmq.RCVHWM, 0)  # a listener should not lose events to its own slowness
    ipv6(sock, endpoint)
    for prefix in protocol.subscriptions(stream, kind):
        sock.setsockopt(zmq.SUBSCRIBE, prefix)
    watch = None if monitor is None else sock.get_monitor_socket(monitor)
    sock.connect(endpoint)
    return sock if watch is None else (sock, watch)


def handshake(sock, control: str, ctx=None, timeout: float = 30.0, curve=None) -> list:
    """Wait until the SUB socket ``sock`` receives what the daemon publishes.

    ZeroMQ gives no sign when a subscription reaches the publisher, and drops what is sent
    before it does. So ask the daemon (control ``hello``) to publish a token on a topic only
    this socket subscribes to, again every 50 ms, until the token arrives. Returns the frames
    of the other events that arrived meanwhile, for :func:`listen` (``pending``): none is lost.
    """
    import secrets

    token = secrets.token_hex(8)
    prefix = protocol.topic("hello", token)
    sock.setsockopt(zmq.SUBSCRIBE, prefix)
    poller = zmq.Poller()
    poller.register(sock, zmq.POLLIN)
    pending, deadline = [], time.monotonic() + timeout
    try:
        while time.monotonic() < deadline:
            reply = request(control, "hello", ctx, timeout=timeout, curve=curve, token=token)
            if not reply.get("ok"):
                raise TimeoutError(f"the daemon refused hello: {reply.get('error')}")
            end = time.monotonic() + 0.05
            while (left := end - time.monotonic()) > 0 and poller.poll(int(left * 1000) + 1):
                frames = sock.recv_multipart()
                if frames[0] == prefix:
                    return pending
                pending.append(frames)
        raise TimeoutError(
            f"no hello from the daemon's publisher in {timeout} s: is "
            "the publish endpoint the one of the daemon at the control endpoint?"
        )
    finally:
        sock.setsockopt(zmq.UNSUBSCRIBE, prefix)


class Subscription:
    """A SUB socket whose subscription is known to be live, with the events that arrived
    during the handshake (:func:`listen` yields them first)."""

    def __init__(self, sock, pending):
        self.sock = sock
        self.pending = list(pending)

    def close(self) -> None:
        self.sock.close()


def subscribe(
    endpoint: str, control: str, stream=None, kind=None, ctx=None, timeout: float = 30.0, curve=None
) -> Subscription:
    """:func:`subscriber` then :func:`handshake`: events published after this returns reach
    the subscription (no sleep, no slow-joiner loss)."""
    sock = subscriber(endpoint, stream, kind, ctx, curve=curve)
    try:
        return Subscription(sock, handshake(sock, control, ctx, timeout, curve=curve))
    except BaseException:
        sock.close()
        raise
