"""Replay to a daemon's ingest: a PUSH socket connected to its PULL, which waits when the
daemon's queue is full (backpressure) and says when no daemon takes the packets."""

from __future__ import annotations

import contextlib
import dataclasses
import time
from pathlib import Path

import numpy as np
import zmq

from streamseg import protocol
from streamseg.client import sending_context
from streamseg.endpoints import ipv6
from streamseg.exceptions import ParameterError
from streamseg.protocol.auth import read_token

#: the characters a stream id may hold (docs/protocol.md, "Stream ids"): ASCII only
_ID_CHARS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_.:@+=-")


def stream_id(path) -> str:
    """The default stream id of ``path``: its name before the first dot, every character a
    stream id may not hold (``/``, spaces, non-ASCII letters) replaced by ``_``."""
    name = Path(path).name.split(".")[0]
    return "".join(c if c in _ID_CHARS else "_" for c in name)[:128] or "stream"


def announce_of(
    recording, stream: str, labels=None, labels_sequence: str | None = None
) -> protocol.Announce:
    """The announce message of ``recording`` as ``stream``; ``labels`` (a label CSV path, made
    absolute so a subscriber in another directory finds it) is passed on to subscribers."""
    sk = recording.skeleton
    return protocol.Announce(
        stream,
        float(recording.fps),
        tuple(sk.names),
        tuple(int(p) for p in sk.parents),
        str(sk.units)[:64],
        sk.up,
        None if labels is None else str(Path(labels).resolve()),
        labels_sequence if labels is not None else None,
    )


def check_pacing(batch: int, speed: float, zero: str = "") -> None:
    """Raise :class:`ParameterError` for a ``--batch`` below 1 or a ``--speed`` below 0 (or
    NaN); ``zero`` says in the message what a speed of 0 does."""
    if batch < 1:
        raise ParameterError(f"--batch {batch} is invalid: expected frames per packet >= 1")
    if not speed >= 0:
        raise ParameterError(
            f"--speed {speed} is invalid: expected times real time >= 0" + (zero and f" ({zero})")
        )


def paced_packets(positions, fps: float, stream: str, speed: float, batch: int):
    """Yield the encoded :class:`protocol.Frames` packets of ``positions`` (n, J, 3), ``batch``
    frames each, each once it is due at ``speed`` times real time from the first (0: at
    once); a packet's time stamp is when it is yielded."""
    t0 = time.perf_counter()
    for a in range(0, positions.shape[0], batch):
        if speed > 0:
            pause = t0 + a / (fps * speed) - time.perf_counter()
            if pause > 0:
                time.sleep(pause)
        yield protocol.encode(protocol.Frames(stream, a, time.time(), positions[a : a + batch]))


class NoDaemon(TimeoutError):
    """No daemon took a packet within the wait."""


class Interrupted(KeyboardInterrupt):
    """Ctrl-C during a replay; ``sent_end``: whether the ``end`` message went out."""

    def __init__(self, sent_end: bool):
        super().__init__(sent_end)
        self.sent_end = sent_end


def _send(sock, parts, wait, endpoint, on_wait=None):
    """Send, waiting at most ``wait`` seconds (None: forever) for the daemon to take it."""
    if wait is not None and not sock.poll(500 if on_wait else int(wait * 1000), zmq.POLLOUT):
        if on_wait is not None:
            on_wait()
            if not sock.poll(int(max(wait - 0.5, 0) * 1000), zmq.POLLOUT):
                raise NoDaemon(
                    f"no daemon took packets at {endpoint} for {wait:g} s: start "
                    f"`streamseg serve` or check --to (and --curve-dir)"
                )
        else:
            raise NoDaemon(
                f"the daemon at {endpoint} took no packet for {wait:g} s (stopped or overloaded)"
            )
    sock.send_multipart(parts)


def replay(
    recording,
    endpoint: str,
    *,
    stream: str,
    speed: float = 1.0,
    batch: int = 1,
    dtype=np.float64,
    ctx: zmq.Context | None = None,
    end: bool = True,
    sock=None,
    labels=None,
    labels_sequence: str | None = None,
    wait: float | None = None,
    on_wait=None,
    curve=None,
) -> int:
    """Send one pass of ``recording`` to ``endpoint``; returns the number of frames sent.

    Parameters
    ----------
    recording : Recording
    endpoint : str
        The daemon's ingest endpoint (PULL; this side connects a PUSH socket).
    speed : float
        Real time times ``speed``; 0 sends as fast as the daemon accepts.
    batch : int
        Frames per packet.
    sock : zmq.Socket, optional
        An already connected PUSH socket (to interleave several streams on one).
    labels, labels_sequence : str, optional
        A human label CSV and its sequence (default: the stream id) to announce.
    wait : float, optional
        Seconds to wait for the daemon to take a packet before raising :class:`NoDaemon`
        (None: wait forever). ``on_wait()`` is called once if the first packet is not taken
        within 0.5 s (to say "waiting for the daemon").
    curve : streamseg.daemon.security.ClientKeys, optional
        CURVE keys for the connection.

    On KeyboardInterrupt the ``end`` message is sent (best effort, 1 s) and :class:`Interrupted`
    raised.
    """
    check_pacing(batch, speed, "0: as fast as the daemon takes the frames")
    own = sock is None
    delivery = contextlib.ExitStack()  # a private context: leaving waits for the queue
    if own:
        ctx = delivery.enter_context(sending_context(ctx))
        sock = ctx.socket(zmq.PUSH)
        sock.setsockopt(zmq.LINGER, 30000)  # deliver what is queued before closing
        if wait is not None:  # writable only once connected: "waiting" is then visible
            sock.setsockopt(zmq.IMMEDIATE, 1)
        if curve is not None:
            curve.apply(sock)
        ipv6(sock, endpoint)
        sock.connect(endpoint)
    positions = np.ascontiguousarray(recording.positions, dtype=dtype)
    n, fps = positions.shape[0], float(recording.fps)
    # without CURVE, the control token lets this user's replay take over its stream id from
    # an earlier sender (one killed mid-take), which a stranger's cannot (docs/protocol.md)
    auth = read_token() if curve is None else None
    try:
        _send(
            sock,
            protocol.encode(
                dataclasses.replace(
                    announce_of(recording, stream, labels, labels_sequence), auth=auth
                )
            ),
            wait,
            endpoint,
            on_wait,
        )
        for packet in paced_packets(positions, fps, stream, speed, batch):
            _send(sock, packet, wait, endpoint)
        if end:
            _send(sock, protocol.encode(protocol.End(stream, auth)), wait, endpoint)
    except KeyboardInterrupt:
        # Ctrl-C means now: at most 1 s to hand over what is queued, never the 30 s linger
        sock.setsockopt(zmq.LINGER, 1000)
        sent_end = bool(end and sock.poll(1000, zmq.POLLOUT))
        if sent_end:
            sock.send_multipart(protocol.encode(protocol.End(stream, auth)), zmq.NOBLOCK)
        raise Interrupted(sent_end) from None
    except NoDaemon:
        sock.setsockopt(zmq.LINGER, 0)
        raise
    finally:
        if own:
            sock.close()
        delivery.close()
    return n
