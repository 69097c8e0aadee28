"""Control requests to the daemon, the context a sender lives in, and telling a refused
security handshake from a daemon that is not there."""

from __future__ import annotations

import contextlib
import time

import msgpack
import zmq
from zmq.utils.monitor import recv_monitor_message

from streamseg import protocol
from streamseg.endpoints import ipv6


@contextlib.contextmanager
def sending_context(ctx: zmq.Context | None = None):
    """The context a sender's sockets live in: ``ctx`` as given, else a private one that is
    terminated on leaving, which waits (up to each socket's linger) until what is queued has
    gone out. pyzmq never terminates ``zmq.Context.instance()`` at interpreter exit, so a
    process that ends right after closing a socket of it loses what is still queued: a
    replay's last packets and its ``end``. Close every socket before leaving."""
    if ctx is not None:
        yield ctx
        return
    own = zmq.Context()
    try:
        yield own
    finally:
        own.term()


def request(endpoint: str, op: str, ctx=None, timeout: float = 5.0, curve=None, **fields) -> dict:
    """One control request (``ping``, ``streams``, ``state``, ``since``, ``stats``,
    ``shutdown``); ``curve``: :class:`~streamseg.daemon.security.ClientKeys`. Without
    ``curve``, a state-changing op carries the control token of this user
    (:mod:`streamseg.protocol.auth`) unless ``auth`` is given."""
    if op in protocol.CHANGING_OPS and curve is None and "auth" not in fields:
        from streamseg.protocol.auth import read_token

        fields["auth"] = read_token()
    body = msgpack.packb({"v": protocol.PROTOCOL_VERSION, "op": op, **fields})
    ctx = ctx or zmq.Context.instance()
    sock = ctx.socket(zmq.REQ)
    sock.setsockopt(zmq.LINGER, 0)
    ipv6(sock, endpoint)
    if curve is not None:
        curve.apply(sock)
    # a refused CURVE handshake is silent on the socket itself: its monitor says so
    monitor = sock.get_monitor_socket(Refusal.EVENTS)
    refusal = Refusal(endpoint, curve)
    sock.connect(endpoint)
    # the request goes out once the socket takes it, never by a blocking send: a handshake
    # refused before it ends the connection and its queue, and a blocking send would wait
    # out the timeout without reading the monitor that says why
    poller = zmq.Poller()
    poller.register(sock, zmq.POLLOUT)
    poller.register(monitor, zmq.POLLIN)
    sent = False
    deadline = time.monotonic() + timeout
    try:
        while (left := deadline - time.monotonic()) > 0:
            ready = dict(poller.poll(int(left * 1000) + 1))
            if sock in ready:
                if sent:
                    return msgpack.unpackb(sock.recv(), raw=False)
                try:
                    sock.send(body, zmq.NOBLOCK)
                    sent = True
                    poller.modify(sock, zmq.POLLIN)
                except zmq.Again:  # the connection ended since the poll: wait again
                    pass
            if monitor in ready:
                refusal.check(recv_monitor_message(monitor)["event"])
    finally:
        sock.disable_monitor()
        monitor.close(linger=0)
        sock.close()
    raise TimeoutError(
        f"no reply from control endpoint {endpoint} in {timeout} s: is "
        "the daemon running there? (with CURVE on it needs --curve-dir)"
    )


class Refusal:
    """Decide from a socket's monitor events that the daemon refuses its handshake.

    A refused key (``AUTH``) or a mechanism mismatch seen by this side (``PROTOCOL``) is
    decisive. But when a CURVE daemon meets a client without CURVE, it may close the
    connection before this side reads its greeting: then only ``NO_DETAIL`` is seen, at each
    reconnection. One such tear can be a daemon stopping; :attr:`TEARS` in a row, with no
    handshake in between that succeeded, are a refusal.
    """

    EVENTS = (
        zmq.EVENT_HANDSHAKE_FAILED_AUTH
        | zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL
        | zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL
        | zmq.EVENT_HANDSHAKE_SUCCEEDED
    )
    TEARS = 3

    def __init__(self, endpoint: str, curve=None):
        self.endpoint, self.curve, self.tears = endpoint, curve, 0

    def check(self, event: int) -> None:
        """Take one monitor event; raise ConnectionRefusedError once the refusal is sure."""
        if event == zmq.EVENT_HANDSHAKE_SUCCEEDED:
            self.tears = 0
            return
        if event == zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL:
            self.tears += 1
            if self.tears < self.TEARS:
                return
        if event == zmq.EVENT_HANDSHAKE_FAILED_AUTH:
            raise ConnectionRefusedError(
                f"the daemon at {self.endpoint} refused this client's CURVE key: copy the "
                "client's public key (client.key of --curve-dir) into the daemon's "
                "authorized/ folder"
            )
        raise ConnectionRefusedError(
            f"the daemon at {self.endpoint} refused the security handshake: "
            + (
                "it has no CURVE keys or other ones (check --curve-dir: its server.key must be "
                "the daemon's)"
                if self.curve is not None
                else "it has CURVE on: give --curve-dir DIR with keys made by `streamseg keys`"
            )
        )
