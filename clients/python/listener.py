"""What any process needs to follow the daemon: pyzmq and msgpack, nothing of streamseg.

    python clients/python/listener.py tcp://127.0.0.1:5561 [STREAM] [--max N]
        [--control tcp://127.0.0.1:5562] [--keys DIR]

Prints one line per cut and relabel (protocol v1, docs/protocol.md) until the stream closes
(or N events). A daemon with the two-stage cut decision (``early_delay_s``) sends some cuts
``pending``; a later ``withdraw`` takes one back (it leaves the list of cuts printed at the
close) and a ``confirm`` says it stands. With --control it first makes sure its subscription
is live (the hello handshake, docs/protocol.md), so it misses nothing published after
"listening on". With ``--keys DIR`` (made by ``streamseg keys DIR``) it connects with CURVE:
its pair from ``client.key_secret``, the daemon's public key from ``server.key``. A template
for clients in other processes or languages.
"""

import os
import sys

import msgpack
import zmq
import zmq.auth


def option(argv, name):
    """The value after ``name`` in argv (both removed), or None."""
    if name not in argv:
        return None
    i = argv.index(name)
    value = argv[i + 1]
    del argv[i:i + 2]
    return value


def use_keys(sock, keys):
    """CURVE on ``sock``: zmq.auth reads ZeroMQ's certificate files made by streamseg keys."""
    try:
        sock.curve_publickey, sock.curve_secretkey = zmq.auth.load_certificate(
            f"{keys}/client.key_secret")
        sock.curve_serverkey, _ = zmq.auth.load_certificate(f"{keys}/server.key")
    except (OSError, ValueError) as err:  # one line, not a traceback
        print(f"--keys {keys}: {err}: make the keys with `streamseg keys DIR`",
              file=sys.stderr)
        sys.exit(2)


def handshake(sub, control, keys=None):
    """Ask the daemon to publish a random token until it arrives: the subscription is live."""
    token = os.urandom(8).hex()
    topic = f"hello/{token}/".encode()
    sub.setsockopt(zmq.SUBSCRIBE, topic)
    req = zmq.Context.instance().socket(zmq.REQ)
    req.setsockopt(zmq.LINGER, 0)
    if keys:
        use_keys(req, keys)
    req.connect(control)
    while True:
        req.send(msgpack.packb({"v": 1, "op": "hello", "token": token}))
        req.recv()
        if sub.poll(50) and sub.recv_multipart()[0] == topic:
            break  # (a real client would keep any other event received here)
    req.close()
    sub.setsockopt(zmq.UNSUBSCRIBE, topic)


def main(argv):
    args = list(argv)
    limit = option(args, "--max")
    limit = int(limit) if limit is not None else None
    control = option(args, "--control")
    keys = option(args, "--keys")
    endpoint, stream = args[0], (args[1] if len(args) > 1 else "")
    sub = zmq.Context.instance().socket(zmq.SUB)
    if keys:
        use_keys(sub, keys)
    sub.connect(endpoint)
    # topics are "<type>/<stream>/": one subscription per event type this client wants
    suffix = f"{stream}/" if stream else ""
    for kind in ("cut", "withdraw", "segments", "closed"):
        sub.setsockopt(zmq.SUBSCRIBE, f"{kind}/{suffix}".encode())
    if control:
        handshake(sub, control, keys)
    print(f"listening on {endpoint}", flush=True)
    seen = 0
    cuts = {}  # stream -> its cut frames, withdrawn ones removed
    two_stage = set()  # streams that sent a pending cut: their final list is printed
    while limit is None or seen < limit:
        topic, body = sub.recv_multipart()
        ev = msgpack.unpackb(body, raw=False)
        if ev.get("v") != 1:
            print(f"skipping protocol version {ev.get('v')}", file=sys.stderr)
            continue
        seen += 1
        if ev["type"] == "cut":
            cuts.setdefault(ev["stream"], []).append(ev["frame"])
            pending = ev.get("pending", False)  # optional field: absent means final
            if pending:
                two_stage.add(ev["stream"])
            print(f"{ev['stream']}: cut at frame {ev['frame']} (decided at {ev['emitted_at']}"
                  f"{', pending' if pending else ''})", flush=True)
        elif ev["type"] == "withdraw":
            frames = cuts.get(ev["stream"], [])
            if ev["frame"] in frames:
                frames.remove(ev["frame"])
            print(f"{ev['stream']}: withdraw of the cut at frame {ev['frame']} "
                  f"(at {ev['emitted_at']})", flush=True)
        elif ev["type"] == "segments":
            runs = ", ".join(f"{a}-{b}:{lab}" for a, b, lab in ev["segments"])
            print(f"{ev['stream']}: relabel {ev['revision']} of {ev['start']}-{ev['end']}: {runs}")
        else:
            final = cuts.pop(ev["stream"], [])
            if ev["stream"] in two_stage:
                print(f"{ev['stream']}: final cuts {sorted(final)}")
            print(f"{ev['stream']}: closed ({ev['reason']})")
            if stream:
                break
    sub.close(linger=0)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
