"""What any process needs to follow the daemon: pyzmq and msgpack, nothing of streamseg.

    python examples/minimal_listener.py tcp://127.0.0.1:5561 [STREAM] [--max N]
        [--control tcp://127.0.0.1:5562]

Prints one line per cut and relabel (protocol v1, docs/protocol.md) until the stream closes
(or N events). With --control it first makes sure its subscription is live (the hello
handshake, docs/protocol.md), so it misses nothing published after "listening on". A
template for clients in other processes or languages.
"""

import os
import sys

import msgpack
import zmq


def option(argv, name):
    """Value of ``--name VALUE`` in argv (removed from it), or None."""
    if name not in argv:
        return None
    i = argv.index(name)
    value = argv[i + 1]
    del argv[i:i + 2]
    return value


def handshake(sub, control):
    """Ask the daemon to publish a random token until it arrives: the subscription is live."""
    token = os.urandom(8).hex()
    topic = f"hello/{token}/".encode()
    sub.setsockopt(zmq.SUBSCRIBE, topic)
    req = zmq.Context.instance().socket(zmq.REQ)
    req.setsockopt(zmq.LINGER, 0)
    req.connect(control)
    while True:
        req.send(msgpack.packb({"v": 1, "op": "hello", "token": token}))
        req.recv()
        if sub.poll(50) and sub.recv_multipart()[0] == topic:
            break  # (a real client would keep any other event received here)
    req.close()
    sub.setsockopt(zmq.UNSUBSCRIBE, topic)


def main(argv):
    argv = list(argv)
    limit = option(argv, "--max")
    limit = int(limit) if limit is not None else None
    control = option(argv, "--control")
    args = argv
    endpoint, stream = args[0], (args[1] if len(args) > 1 else "")
    sub = zmq.Context.instance().socket(zmq.SUB)
    sub.connect(endpoint)
    # topics are "<type>/<stream>/": one subscription per event type this client wants
    suffix = f"{stream}/" if stream else ""
    for kind in ("cut", "segments", "closed"):
        sub.setsockopt(zmq.SUBSCRIBE, f"{kind}/{suffix}".encode())
    if control:
        handshake(sub, control)
    print(f"listening on {endpoint}", flush=True)
    seen = 0
    while limit is None or seen < limit:
        topic, body = sub.recv_multipart()
        ev = msgpack.unpackb(body, raw=False)
        if ev.get("v") != 1:
            print(f"skipping protocol version {ev.get('v')}", file=sys.stderr)
            continue
        seen += 1
        if ev["type"] == "cut":
            print(f"{ev['stream']}: cut at frame {ev['frame']} (decided at {ev['emitted_at']})",
                  flush=True)
        elif ev["type"] == "segments":
            runs = ", ".join(f"{a}-{b}:{lab}" for a, b, lab in ev["segments"])
            print(f"{ev['stream']}: relabel {ev['revision']} of {ev['start']}-{ev['end']}: {runs}")
        else:
            print(f"{ev['stream']}: closed ({ev['reason']})")
            if stream:
                break
    sub.close(linger=0)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
