"""The daemon's ingest: the PULL socket, a receiver thread, and a queue bounded in bytes.

:class:`Ingest` owns the ingest socket. Its options, the message bound ``RCVHWM`` included,
are set once, before bind, and never changed on the live socket: libzmq 4.3.5 forwards a new
bound to the peer of every pipe, and the peer of a connection that is ending may already be
freed (the daemon died of SIGSEGV; docs/decisions.md, Ingest memory). A thread of its own
reads the socket continuously, decodes each message (:func:`decode_ingest`) and queues it;
the loop takes the queued messages (:meth:`Ingest.take`). The queue is bounded in bytes over
every connection together (``ingest_bytes`` less what ZeroMQ may hold), in messages and in
frames (the latency); when it is full the thread stops reading, ZeroMQ's per-connection
queues fill up to their fixed bound and PUSH senders wait: backpressure, nothing dropped.
"""

from __future__ import annotations

import collections
import threading
import time
from typing import NamedTuple

import numpy as np
import zmq

from streamseg import protocol


class FramesItem(NamedTuple):
    """A decoded frames packet (the fast path: no :class:`~streamseg.protocol.Frames`)."""

    stream: str
    seq: int
    timestamp: float
    positions: np.ndarray  # (n, joints, 3), a read-only view on the message
    arrival: float  # perf_counter() when received
    sender: zmq.Frame  # the topic frame: who sent it (security.peer_of)


class BodyItem(NamedTuple):
    """Another valid ingest message (announce, end, or a frames body for the slow path)."""

    body: dict
    sender: zmq.Frame
    nbytes: int
    subscribed: bool = False  # came through a subscription (``subscribe``), not PULL


class BadItem(NamedTuple):
    """A message that could not be decoded: reported as an ``error`` event."""

    stream: str | None
    reason: str
    message: str


def recv_message(sock, flags: int = 0) -> list:
    """One multipart message: the topic as a ``zmq.Frame`` (it carries the sender's identity,
    see :func:`streamseg.daemon.security.peer_of`), the other parts as bytes. Faster than
    ``recv_multipart`` too (measured 1.8 against 3.0-5.3 us per 2-part message)."""
    first = sock.recv(flags, copy=False)
    parts = [first]
    more = first.more
    while more:
        parts.append(sock.recv())
        more = sock.getsockopt(zmq.RCVMORE)
    return parts


def decode_ingest(
    parts, arrival: float, subscribed: bool = False
) -> FramesItem | BodyItem | BadItem:
    """The queue item of one received multipart message (``subscribed``: from a SUB)."""
    if len(parts) != 2:
        return BadItem(None, "decode", f"expected 2 message parts [topic, body], got {len(parts)}")
    try:
        obj = protocol.unpack_body(parts[1])
        stream = obj.get("stream")
        if obj["type"] == "frames" and type(stream) is str:
            return FramesItem(stream, *protocol.frames_fields(obj, stream), arrival, parts[0])
        return BodyItem(obj, parts[0], len(parts[1]), subscribed)
    except protocol.WireError as err:
        return BadItem(err.stream, err.kind, str(err))
    except Exception as err:  # a packet validation missed must not stop the receiver
        return BadItem(None, "decode", f"packet could not be handled ({type(err).__name__}: {err})")


def item_bytes(it) -> int:
    """Bytes an item holds (its positions, or its message)."""
    if type(it) is FramesItem:
        return it.positions.nbytes
    return it.nbytes if type(it) is BodyItem else 0


def item_frames(it) -> int:
    return it.positions.shape[0] if type(it) is FramesItem else 0


# libzmq 4.3.5 holds back packets of an ipc connection that reconnected (the daemon
# restarted) and reached a small bound, until the sender's next packet: a burst's `end` never
# arrived (87 of 88 packets at a bound of 4 or 16; the soak without a ZAP handler: ~100
# streams left open at a kill). An ipc ingest therefore keeps at least this many packets per
# connection, so that a burst does not reach the bound (docs/decisions.md, Ingest memory)
IPC_MIN_HWM = 1000
RECV_TIMEOUT_MS = 50  # the receiver's blocking receive returns this often to see a stop


class IngestBounds(NamedTuple):
    """What the ingest may hold, from the configuration (fixed for the socket's life).

    ``hwm`` messages per connection in ZeroMQ, ``queue_bytes`` bytes, ``queue_items``
    messages and ``queue_frames`` frames in the receiver's queue.
    """

    hwm: int
    queue_bytes: int
    queue_items: int
    queue_frames: int

    @classmethod
    def of(cls, config) -> IngestBounds:
        # half the budget for the receiver's queue, at least one largest message; the other
        # half is what ZeroMQ holds of the connections that send large packets
        # (docs/decisions.md, Ingest memory)
        queue = max(config.ingest_bytes // 2, config.max_message_bytes)
        hwm = config.ingest_hwm
        if config.ingest.startswith("ipc://"):
            hwm = max(hwm, IPC_MIN_HWM)
        return cls(hwm, queue, config.drain, config.drain_frames)


class Ingest:
    """The ingest socket, read by a thread of its own into a queue bounded in bytes.

    Parameters
    ----------
    ctx : zmq.Context
        The daemon's context.
    config : streamseg.config.DaemonConfig
        ``ingest`` (endpoint), ``ingest_hwm``, ``ingest_bytes``, ``max_message_bytes``,
        ``drain``, ``drain_frames``.
    secure : callable
        Applies the daemon's security (CURVE or connection names) to a socket before bind.

    Notes
    -----
    Counters are each written by one thread only: ``pushed*`` by the receiver, ``taken*`` by
    the loop; what is queued is their difference.
    """

    def __init__(self, ctx: zmq.Context, config, secure):
        from streamseg.endpoints import ipv6

        self.bounds = IngestBounds.of(config)
        self.sock = ctx.socket(zmq.PULL)
        secure(self.sock)
        # every option before bind: none is ever changed on the live socket
        self.sock.setsockopt(zmq.RCVHWM, self.bounds.hwm)
        self.sock.setsockopt(zmq.LINGER, 0)
        self.sock.setsockopt(zmq.MAXMSGSIZE, config.max_message_bytes)
        self.sock.setsockopt(zmq.RCVTIMEO, RECV_TIMEOUT_MS)
        ipv6(self.sock, config.ingest)
        self.sub = None
        if config.subscribe:
            # publishers of frame packets: no backpressure, so a fixed queue of its own (a
            # publisher drops beyond it; the daemon sees the frames missing: `gap` events)
            self.sub = ctx.socket(zmq.SUB)
            self.sub.setsockopt(zmq.RCVHWM, config.subscribe_hwm)
            self.sub.setsockopt(zmq.LINGER, 0)
            self.sub.setsockopt(zmq.MAXMSGSIZE, config.max_message_bytes)
            self.sub.setsockopt(zmq.SUBSCRIBE, b"")
            for ep in config.subscribe:
                ipv6(self.sub, ep)
        self.subscribe = tuple(config.subscribe)
        self.ctx = ctx
        self.items: collections.deque = collections.deque()
        self.pushed = self.taken = 0  # frames
        self.pushed_bytes = self.taken_bytes = 0
        self.pushed_items = self.taken_items = 0
        self.peak_bytes = 0  # most bytes queued at once (stats)
        self.waits = 0  # times the queue was full and reading stopped
        self._room = threading.Event()  # set by the loop when it takes items
        self._waiting = False  # the thread waits for room (the loop then sets _room)
        self._woken = False  # a wake-up byte is out that the loop has not read yet
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._run, name="streamseg-ingest", daemon=True)
        self.wake = None  # PAIR the loop polls: one byte per batch queued
        self._wake_tx = None

    def bind(self, endpoint: str) -> str:
        """Bind the socket (and connect the subscriptions); returns the endpoint bound (a
        port of 0 resolved)."""
        self.sock.bind(endpoint)
        for ep in self.subscribe:
            self.sub.connect(ep)
        name = f"inproc://streamseg-wake-{id(self)}"
        self.wake = self.ctx.socket(zmq.PAIR)
        self.wake.bind(name)
        self._wake_tx = self.ctx.socket(zmq.PAIR)
        self._wake_tx.connect(name)
        return self.sock.getsockopt_string(zmq.LAST_ENDPOINT)

    def start(self) -> None:
        self._thread.start()

    @property
    def queued_bytes(self) -> int:
        return self.pushed_bytes - self.taken_bytes

    def _full(self) -> bool:
        b = self.bounds
        return (
            self.pushed_items - self.taken_items >= b.queue_items
            or self.pushed - self.taken >= b.queue_frames
            or self.pushed_bytes - self.taken_bytes >= b.queue_bytes
        )

    def _wait_for_room(self) -> None:
        """The loop is behind: stop reading (senders wait) until it takes some."""
        self.waits += 1
        self._room.clear()
        self._waiting = True
        if self._full():
            self._room.wait(0.05)
        self._waiting = False

    def _push(self, it) -> None:
        self.pushed += item_frames(it)
        self.pushed_bytes += item_bytes(it)
        self.pushed_items += 1
        self.items.append(it)
        q = self.pushed_bytes - self.taken_bytes
        if q > self.peak_bytes:
            self.peak_bytes = q
        # one wake-up until the loop reads it (clear_wake), not one per message: the loop
        # takes whatever is queued by then
        if not self._woken:
            self._woken = True
            try:
                self._wake_tx.send(b"", zmq.NOBLOCK)
            except zmq.Again:  # the loop has wake-ups pending already
                pass

    def _run(self) -> None:
        try:
            if self.sub is None:
                self._run_blocking()
            else:
                self._run_polling()
        finally:
            self._wake_tx.close(linger=0)

    def _run_blocking(self) -> None:
        # a blocking receive (RCVTIMEO, set before bind, lets it see _stopping): ZeroMQ waits
        # for the next message in C without the GIL, no poll and no zmq.Again per message
        # (1 frame per packet: 1.2-1.4x the frames/s of poll + NOBLOCK, docs/decisions.md)
        sock, clock = self.sock, time.perf_counter
        while not self._stopping.is_set():
            if self._full():
                self._wait_for_room()
                continue
            try:
                parts = recv_message(sock)
            except zmq.Again:  # RCVTIMEO: nothing came
                continue
            self._push(decode_ingest(parts, clock()))

    def _run_polling(self) -> None:
        # two sockets (the PULL and the subscriptions' SUB): poll both
        poller = zmq.Poller()
        poller.register(self.sock, zmq.POLLIN)
        poller.register(self.sub, zmq.POLLIN)
        clock = time.perf_counter
        while not self._stopping.is_set():
            if self._full():
                self._wait_for_room()
                continue
            for sock, _ in poller.poll(50):
                subscribed = sock is self.sub
                for _ in range(256):
                    try:
                        parts = recv_message(sock, zmq.NOBLOCK)
                    except zmq.Again:
                        break
                    self._push(decode_ingest(parts, clock(), subscribed))
                    if self._full():
                        break

    def clear_wake(self) -> None:
        """The loop woke on :attr:`wake`: read its pending bytes (the next message queued
        wakes it again)."""
        self._woken = False  # before reading: a message queued meanwhile sends a new byte
        while self.wake.poll(0):
            self.wake.recv()

    def take(self, max_items: int, max_frames: int, until: float | None = None):
        """Yield queued items, oldest first, at most ``max_items`` and, once ``max_frames``
        frames are out or ``time.perf_counter()`` passed ``until``, no more (the loop
        thread)."""
        items = self.items
        frames = 0
        for _ in range(max_items):
            if not items or (until is not None and time.perf_counter() > until):
                break
            it = items.popleft()
            n = item_frames(it)
            self.taken += n
            self.taken_bytes += item_bytes(it)
            self.taken_items += 1
            if self._waiting:
                self._room.set()
            yield it
            frames += n
            if frames >= max_frames:
                break

    def stop(self) -> None:
        """Stop reading (queued items stay for :meth:`take`)."""
        self._stopping.set()
        self._room.set()
        if self._thread.is_alive():
            self._thread.join(5)
        elif self._wake_tx is not None and not self._wake_tx.closed:
            self._wake_tx.close(linger=0)  # never started: _run did not close it

    def close(self) -> None:
        for sock in (self.sock, self.sub, self.wake):
            if sock is not None:
                sock.close()

    def stats(self) -> dict:
        """Totals for ``stats``: the fixed bound, what is queued, and how often it was full."""
        return {
            "ingest_hwm": self.bounds.hwm,
            "ingest_queued_bytes": self.queued_bytes,
            "ingest_peak_bytes": self.peak_bytes,
            "ingest_waits": self.waits,
        }
