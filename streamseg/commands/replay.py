"""Replay a recording as a live stream to a daemon's ingest endpoint.

Announces the stream, sends N frames per packet at real time times ``--speed`` (``0``: as fast
as the daemon takes them; a PUSH socket waits when the daemon's queue is full), then ends it.
With no daemon listening it says it is waiting and gives up after ``--wait`` seconds; Ctrl-C
(SIGINT) or SIGTERM sends ``end`` before it exits, so the daemon closes the stream at once.
"""

from __future__ import annotations

import contextlib
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np
import zmq

from streamseg import protocol
from streamseg.client import sending_context
from streamseg.endpoints import ipv6
from streamseg.exceptions import ParameterError
from streamseg.protocol.auth import read_token
from streamseg.recording import UP_AXES


def add_arguments(parser) -> None:
    from streamseg.commands.args import endpoint, frame_rate
    from streamseg.commands.inputs import add_source_arguments

    parser.add_argument(
        "file", help="recording (.amc[.gz], .bvh, .c3d, .trc, .npz; joint positions .csv/.npy/.npz)"
    )
    parser.add_argument("--skeleton", help="ASF skeleton file (needed for AMC)")
    parser.add_argument(
        "--fps",
        type=frame_rate,
        default=None,
        help="frame rate of positions without a time column; replaces the file's own",
    )
    add_source_arguments(parser)
    parser.add_argument(
        "--to",
        type=endpoint,
        metavar="ENDPOINT",
        help="daemon ingest endpoint (PUSH: the daemon's pace)",
    )
    parser.add_argument(
        "--publish",
        type=endpoint,
        metavar="ENDPOINT",
        help="instead of --to: publish the stream on this endpoint (a PUB "
        "socket bound here), as a mocap bridge does, for daemons "
        "started with --subscribe ENDPOINT; the announce is repeated "
        "every second for subscribers that join late",
    )
    parser.add_argument("--speed", type=float, default=1.0, help="times real time; 0 = max")
    parser.add_argument("--stream", help="stream id (default: the file's stem)")
    parser.add_argument("--batch", type=int, default=1, metavar="N", help="frames per packet")
    parser.add_argument("--loop", action="store_true", help="start over at the end, forever")
    parser.add_argument("--float32", action="store_true", help="send float32 positions")
    parser.add_argument(
        "--wait",
        type=float,
        default=10.0,
        metavar="S",
        help="give up when the daemon takes no packet for S seconds (default 10)",
    )
    parser.add_argument(
        "--curve-dir",
        metavar="DIR",
        help="CURVE keys made by `streamseg keys DIR` (client.key_secret, server.key)",
    )
    parser.add_argument(
        "--up",
        choices=UP_AXES,
        help="announce this world up axis (default: the format's, y for AMC/BVH)",
    )
    parser.add_argument(
        "--labels",
        metavar="CSV",
        help="announce this human label file (sequence,start_frame,end_frame,"
        "action_label): `streamseg view` overlays it and shows agreement",
    )
    parser.add_argument(
        "--labels-sequence",
        metavar="NAME",
        help="the label file's sequence to use (default: the file's stem)",
    )


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
    if batch < 1:
        raise ParameterError(f"--batch {batch} is invalid: expected frames per packet >= 1")
    if not speed >= 0:
        raise ParameterError(
            f"--speed {speed} is invalid: expected times real time >= 0 "
            "(0: as fast as the daemon takes the frames)"
        )
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
        t0 = time.perf_counter()
        for a in range(0, n, batch):
            if speed > 0:
                pause = t0 + a / (fps * speed) - time.perf_counter()
                if pause > 0:
                    time.sleep(pause)
            _send(
                sock,
                protocol.encode(protocol.Frames(stream, a, time.time(), positions[a : a + batch])),
                wait,
                endpoint,
            )
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


def run(args) -> int:
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return _run(args)
    # SIGTERM (systemd, timeout, kill) ends the stream like Ctrl-C: `end` goes out first
    previous = signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        return _run(args)
    finally:
        signal.signal(signal.SIGTERM, previous)


def _run(args) -> int:
    # the command's own context: it ends only once the queued packets are out (or the
    # linger is over), never losing the last ones as an exit from Context.instance() does
    with sending_context() as ctx:
        return _replay_command(args, ctx)


def _replay_command(args, ctx) -> int:
    from streamseg.commands.inputs import read_recording

    # what the daemon would refuse, refused here: it would only log it, and we would say "sent"
    if args.stream is not None and not protocol.valid_stream_id(args.stream):
        raise ParameterError(
            f"--stream {args.stream!r} is not a valid stream id: use 1-128 "
            "characters of A-Z a-z 0-9 _ . : @ + = - (docs/protocol.md)"
        )
    if not args.wait > 0:
        raise ParameterError(f"--wait {args.wait:g} is invalid: expected seconds > 0")
    if (args.to is None) == (args.publish is None):
        raise ParameterError(
            "give --to ENDPOINT (a daemon's ingest) or --publish ENDPOINT "
            "(publish for daemons that subscribe), one of them"
        )
    if args.labels:  # the view reads them later, elsewhere: a wrong path is said now
        from streamseg.evaluation.labels import read_labels

        if not Path(args.labels).is_file():
            raise ParameterError(
                f"--labels {args.labels}: no such file (a label CSV: "
                "sequence,start_frame,end_frame,action_label)"
            )
        read_labels(args.labels, args.labels_sequence or stream_id(args.file))
    rec = read_recording(args)
    if args.up:
        rec = dataclasses.replace(rec, skeleton=dataclasses.replace(rec.skeleton, up=args.up))
    stream = args.stream or stream_id(args.file)
    dtype = np.float32 if args.float32 else np.float64
    curve = None
    if args.curve_dir:
        from streamseg.daemon.security import ClientKeys

        curve = ClientKeys.load(args.curve_dir)
    passes = 0

    def waiting():
        print(
            f"streamseg replay: waiting for the daemon at {args.to} (up to {args.wait:g} s)",
            file=sys.stderr,
            flush=True,
        )

    if args.publish is not None:
        return _publish_run(args, rec, stream, dtype, ctx)
    while True:
        try:
            sent = replay(
                rec,
                args.to,
                stream=stream,
                speed=args.speed,
                batch=args.batch,
                dtype=dtype,
                ctx=ctx,
                labels=args.labels,
                labels_sequence=args.labels_sequence
                or (stream_id(args.file) if args.labels else None),
                wait=args.wait,
                on_wait=waiting,
                curve=curve,
            )
        except NoDaemon as err:
            print(f"streamseg replay: {err}", file=sys.stderr)
            return 1
        except KeyboardInterrupt as err:
            if getattr(err, "sent_end", False):
                print(
                    f"streamseg replay: interrupted: sent end of {stream} to {args.to}",
                    file=sys.stderr,
                )
            else:
                print(
                    f"streamseg replay: interrupted: could not send end of {stream} (the "
                    f"daemon at {args.to} took no packet for 1 s); it closes the stream "
                    "when idle",
                    file=sys.stderr,
                )
            return 130
        passes += 1
        print(
            f"streamseg replay: {stream}: sent {sent} frames ({passes} pass"
            f"{'es' if passes > 1 else ''}) to {args.to}",
            flush=True,
        )
        if not args.loop:
            return 0


REANNOUNCE_S = 1.0  # a publisher's announce is repeated this often (late subscribers)


def publish(
    recording,
    endpoint: str,
    *,
    stream: str,
    speed: float = 1.0,
    batch: int = 1,
    dtype=np.float64,
    ctx: zmq.Context | None = None,
    end: bool = True,
    settle: float = 1.0,
    sock=None,
) -> int:
    """Publish one pass of ``recording`` on a PUB socket bound at ``endpoint`` (or ``sock``,
    already bound); returns the frames sent.

    A publisher has no backpressure: at ``speed`` 0 it sends as fast as it can and a
    subscriber that cannot keep up loses packets (the daemon reports them as ``gap``
    events). The announce goes out every :data:`REANNOUNCE_S` seconds, so a daemon that
    subscribes late still opens the stream; ``settle`` seconds pass after binding before the
    first packet, for subscribers to connect.
    """
    if batch < 1:
        raise ParameterError(f"--batch {batch} is invalid: expected frames per packet >= 1")
    if not speed >= 0:
        raise ParameterError(f"--speed {speed} is invalid: expected times real time >= 0")
    own = sock is None
    delivery = contextlib.ExitStack()
    if own:
        ctx = delivery.enter_context(sending_context(ctx))
        sock = ctx.socket(zmq.PUB)
        sock.setsockopt(zmq.LINGER, 2000)
        ipv6(sock, endpoint)
        sock.bind(endpoint)
    positions = np.ascontiguousarray(recording.positions, dtype=dtype)
    n, fps = positions.shape[0], float(recording.fps)
    announce = protocol.encode(announce_of(recording, stream))
    try:
        time.sleep(settle)
        sock.send_multipart(announce)
        t0 = last = time.perf_counter()
        for a in range(0, n, batch):
            now = time.perf_counter()
            if now - last >= REANNOUNCE_S:
                sock.send_multipart(announce)
                last = now
            if speed > 0:
                pause = t0 + a / (fps * speed) - now
                if pause > 0:
                    time.sleep(pause)
            sock.send_multipart(
                protocol.encode(protocol.Frames(stream, a, time.time(), positions[a : a + batch]))
            )
        if end:
            sock.send_multipart(protocol.encode(protocol.End(stream)))
    finally:
        if own:
            sock.close()
        delivery.close()
    return n


def _publish_run(args, rec, stream, dtype, ctx) -> int:
    passes = 0
    sock = ctx.socket(zmq.PUB)
    sock.setsockopt(zmq.LINGER, 2000)
    ipv6(sock, args.publish)
    try:
        sock.bind(args.publish)
    except zmq.ZMQError as err:
        raise ParameterError(
            f"--publish {args.publish}: cannot bind there ({err}); give a "
            "free address, e.g. tcp://127.0.0.1:5570"
        ) from None
    print(f"streamseg replay: publishing {stream} at {args.publish}", flush=True)
    try:
        while True:
            try:
                sent = publish(
                    rec,
                    args.publish,
                    stream=stream,
                    speed=args.speed,
                    batch=args.batch,
                    dtype=dtype,
                    sock=sock,
                    settle=1.0 if passes == 0 else 0.0,
                )
            except KeyboardInterrupt:
                sock.send_multipart(protocol.encode(protocol.End(stream)))
                print(f"streamseg replay: interrupted: published end of {stream}", file=sys.stderr)
                return 130
            passes += 1
            print(
                f"streamseg replay: {stream}: published {sent} frames ({passes} pass"
                f"{'es' if passes > 1 else ''}) at {args.publish}",
                flush=True,
            )
            if not args.loop:
                return 0
    finally:
        sock.close()
