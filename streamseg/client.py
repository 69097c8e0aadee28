"""The Python client of the daemon's protocol (docs/protocol.md).

Control requests (:func:`request`), subscriptions that are known to be live
(:func:`subscribe`: :func:`subscriber` then :func:`handshake`), the event log
(:func:`fetch_since`) and the event iterator with its stop conditions, late-joiner filtering
and hole filling (:func:`listen`). ``streamseg listen`` is this with a command line and
printing; programs (the demo, the tests, a client of your own) import it from here.
"""

from __future__ import annotations

import contextlib
import time

import msgpack
import zmq
from zmq.utils.monitor import recv_monitor_message

from streamseg import protocol
from streamseg.endpoints import ipv6

__all__ = [
    "Refusal",
    "Subscription",
    "fetch_since",
    "handshake",
    "listen",
    "request",
    "takes",
    "sending_context",
    "subscribe",
    "subscriber",
]


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


class _ConnectWait:
    """Whether a SUB socket's connection to its publisher stands, from its monitor events;
    how long it has not, and what to say about it (see :func:`listen`)."""

    def __init__(self, limit, on_waiting, endpoint):
        self.limit, self.on_waiting, self.endpoint = limit, on_waiting, endpoint
        self.since = time.monotonic()  # without a connection since; None while connected
        self.said = False

    def on_event(self, event: int) -> None:
        if event == zmq.EVENT_HANDSHAKE_SUCCEEDED:
            self.since, self.said = None, False
        elif event == zmq.EVENT_DISCONNECTED and self.since is None:
            self.since = time.monotonic()

    def next_check(self):
        """When :meth:`check` has something to do next (None: nothing)."""
        if self.since is None:
            return None
        if not self.said and self.on_waiting is not None:
            return self.since + 1.0
        return None if self.limit is None else self.since + self.limit

    def check(self) -> None:
        if self.since is None:
            return
        waited = time.monotonic() - self.since
        if not self.said and self.on_waiting is not None and waited >= 1.0:
            self.said = True
            more = "" if self.limit is None else f" (giving up after {self.limit:g} s)"
            self.on_waiting(f"waiting for a daemon at {self.endpoint}{more}")
        if self.limit is not None and waited >= self.limit:
            raise TimeoutError(
                f"no daemon at {self.endpoint} for {self.limit:g} s: is "
                "`streamseg serve` running, and is this its publish endpoint? "
                "(--timeout waits longer)"
            )


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


def takes(events) -> list:
    """A stream id's events split into its takes at each ``closed``, in the order given (a
    re-announced id's new take follows its old one's ``closed``); the last, still open take
    (no ``closed`` yet) too."""
    out, cur = [], []
    for e in events:
        cur.append(e)
        if e.type == "closed":
            out.append(cur)
            cur = []
    return out + ([cur] if cur else [])


def fetch_since(
    endpoint: str,
    stream: str,
    seq: int,
    ctx=None,
    upto=None,
    curve=None,
    on_range=None,
    skipped=None,
) -> list:
    """The logged events of ``stream`` with sequence numbers in ``(seq, upto)`` (all after
    ``seq`` when ``upto`` is None) from the control op ``since``, page by page; raises
    LookupError when the daemon keeps no log. ``on_range(first, last)`` is called with the
    first reply's lowest number held and the stream's newest one; ``skipped``, a list, gets
    the ranges ``[lo, hi]`` of numbers above ``seq`` the daemon skipped at a restart."""
    out = []
    while True:
        reply = request(endpoint, "since", ctx, curve=curve, stream=stream, seq=seq)
        if not reply.get("ok"):
            raise LookupError(reply.get("error"))
        if skipped is not None:
            skipped += [r for r in reply.get("skipped", []) if r not in skipped]
        if on_range is not None:
            on_range(reply.get("first") or 0, reply.get("last") or 0)
            on_range = None
        for body in reply["events"]:
            ev = protocol.from_body(body)
            if upto is not None and ev.seq >= upto:
                return out
            out.append(ev)
            seq = ev.seq
        if not reply.get("more"):
            return out


def count_in(ranges, lo: int, hi: int) -> int:
    """How many of the numbers ``lo..hi`` (inclusive) lie in the ranges ``[[a, b], ...]``."""
    return sum(max(0, min(b, hi) - max(a, lo) + 1) for a, b in ranges)


def listen(
    sock,
    *,
    stream=None,
    count=None,
    until_end=False,
    timeout=None,
    since=None,
    backlog=(),
    on_hole=None,
    pending=(),
    monitor=None,
    on_monitor=None,
    connect_timeout=None,
    on_waiting=None,
    endpoint="the daemon",
):
    """Yield decoded events from a SUB socket until a stop condition.

    ``since`` is a control ``state`` reply: segments of revision <= its revision and cuts at
    or before its newest cut are skipped (they are in the state already), until the stream
    is closed (a snapshot of an already closed stream filters nothing). ``pending``: frames
    received during :func:`handshake`, read before the socket. ``backlog``: events fetched
    from the event log (of one stream or several, each in order), yielded first; live events
    they already hold (by sequence number) are skipped; with ``until_end`` the iterator stops
    after them when the history of one of their streams ends with its ``closed``.
    ``on_hole(key, first, end)`` is called when a stream's sequence numbers skip
    ``[first, end)`` (only meaningful when every event type of the stream is subscribed), or
    when a ``stats`` heartbeat says a stream's last number is beyond the last
    one received (a loss at the tail); it returns the missing events it could fetch, which
    are yielded then. With ``stream`` given, ``stats`` events (subscribed for that) are used
    for the tail and not yielded.
    ``monitor``: a monitor socket of ``sock``; ``on_monitor(event)`` is called with each of its
    events (it may raise: a refused handshake is silent on the socket itself).

    ``timeout``: raise TimeoutError after that many seconds without an event.
    ``connect_timeout`` (needs ``monitor`` with ``EVENT_HANDSHAKE_SUCCEEDED`` and
    ``EVENT_DISCONNECTED``): raise TimeoutError when no connection to the publisher
    (``endpoint``) stands for that many seconds, at the start or after it was lost;
    ``on_waiting(text)`` is called once a second has passed without one, saying so.
    """
    if isinstance(sock, Subscription):
        pending, sock.pending = list(sock.pending) + list(pending), []
        sock = sock.sock
    if since and since.get("closed"):
        since = None  # the snapshot is of a closed stream: later events are a new one
    rev = since.get("revision", 0) if since else 0
    last_cut = max((c["frame"] for c in since.get("cuts", [])), default=-1) if since else -1
    seen = 0
    last: dict = {}  # stream id (or "*") -> last sequence number yielded
    fetched: dict = {}  # stream id -> highest sequence number yielded from the log
    newest_type: dict = {}  # stream id -> the type of its last event in the backlog
    for ev in backlog:
        key = ev.stream or protocol.DAEMON_WIDE
        last[key] = fetched[key] = ev.seq
        newest_type[key] = ev.type
        seen += 1
        yield ev
        if count is not None and seen >= count:
            return
    if until_end and "closed" in newest_type.values():
        return  # a stream's history ends with it closed (earlier closes: re-announced)
    poller = zmq.Poller()
    poller.register(sock, zmq.POLLIN)
    if monitor is not None:
        poller.register(monitor, zmq.POLLIN)
    pending = list(pending)
    wait = _ConnectWait(connect_timeout, on_waiting, endpoint) if monitor is not None else None
    idle_end = None if timeout is None else time.monotonic() + timeout
    while count is None or seen < count:
        if pending:
            frames = pending.pop(0)
        else:
            now = time.monotonic()
            ends = [t for t in (idle_end, wait and wait.next_check()) if t is not None]
            ready = dict(
                poller.poll(None if not ends else max(0, int((min(ends) - now) * 1000)) + 1)
            )
            if wait is not None:
                wait.check()
            if not ready:
                if idle_end is not None and time.monotonic() >= idle_end:
                    raise TimeoutError(f"no event for {timeout} s")
                continue
            if monitor in ready:
                event = recv_monitor_message(monitor)["event"]
                if wait is not None:
                    wait.on_event(event)
                if event != zmq.EVENT_DISCONNECTED and on_monitor is not None:
                    on_monitor(event)
            if sock not in ready:
                continue
            frames = sock.recv_multipart()
            # (the heartbeats a one-stream listener reads for the tail are no event of it)
            if timeout is not None and (stream is None or not frames[0].startswith(b"stats/")):
                idle_end = time.monotonic() + timeout
        try:
            ev = protocol.decode(frames)
        except protocol.WireError:
            continue
        if ev.type == "hello":
            continue
        if since is not None and getattr(ev, "stream", None) == since.get("stream"):
            if (ev.type == "segments" and ev.revision <= rev) or (
                ev.type == "cut" and ev.frame <= last_cut
            ):
                continue
            if ev.type == "closed":
                since = None  # a re-announced stream starts its revisions and frames over
        n = getattr(ev, "seq", None)
        missed = ()
        if ev.type == "stats" and on_hole is not None:
            # the heartbeat's last numbers: a loss after a stream's last event received shows
            missed = []
            for key, newest in ev.last_seq.items():
                prev = last.get(key)
                if prev is not None and newest > prev and (stream is None or key == stream):
                    missed += on_hole(key, prev + 1, newest + 1) or ()
                    last[key] = newest
            if stream is not None:  # not the stream's own: yield only what it fetched
                for e in missed:
                    seen += 1
                    yield e
                    if until_end and e.type == "closed" and e.stream == stream:
                        return
                    if count is not None and seen >= count:
                        return
                continue
        elif n is not None:
            key = ev.stream or protocol.DAEMON_WIDE
            if n <= fetched.get(key, 0):
                continue  # already yielded from the log
            prev = last.get(key)
            if prev is not None and n > prev + 1 and on_hole is not None:
                missed = on_hole(key, prev + 1, n) or ()
            last[key] = n
        for e in (*missed, ev):
            seen += 1
            yield e
            if until_end and e.type == "closed" and (stream is None or e.stream == stream):
                return
            if count is not None and seen >= count:
                return
