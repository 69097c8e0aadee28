"""Replay as a publisher (``replay --publish``): a PUB socket that daemons subscribe to, with
no backpressure, re-announcing the stream for subscribers that join late."""

from __future__ import annotations

import contextlib
import sys
import time

import numpy as np
import zmq

from streamseg import protocol
from streamseg.client import sending_context
from streamseg.commands.replay_push import announce_of, check_pacing, paced_packets
from streamseg.endpoints import ipv6
from streamseg.exceptions import ParameterError

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
    check_pacing(batch, speed)
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
        last = time.perf_counter()
        for packet in paced_packets(positions, fps, stream, speed, batch):
            now = time.perf_counter()
            if now - last >= REANNOUNCE_S:
                sock.send_multipart(announce)
                last = now
            sock.send_multipart(packet)
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
