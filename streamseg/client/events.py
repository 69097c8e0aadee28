"""The event iterator (:func:`listen`): stop conditions, late-joiner filtering, holes in the
sequence numbers filled, and the wait for a publisher that is not (or no longer) there."""

from __future__ import annotations

import time

import zmq
from zmq.utils.monitor import recv_monitor_message

from streamseg import protocol
from streamseg.client.subscription import Subscription


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
