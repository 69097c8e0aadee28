"""What any process needs to follow the daemon: pyzmq and msgpack, nothing of streamseg.

    python clients/minimal_listener.py tcp://127.0.0.1:5561 [STREAM] [--max N] [--keys DIR]

Prints one line per cut and relabel (protocol v1, docs/protocol.md) until the stream closes
(or N events). A template for clients in other processes or languages. With ``--keys DIR``
(made by ``streamseg keys DIR``) it connects with CURVE: its pair from ``client.key_secret``,
the daemon's public key from ``server.key``.
"""

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


def main(argv):
    args = list(argv)
    limit = option(args, "--max")
    limit = int(limit) if limit is not None else None
    keys = option(args, "--keys")
    endpoint, stream = args[0], (args[1] if len(args) > 1 else "")
    sub = zmq.Context.instance().socket(zmq.SUB)
    if keys:  # CURVE: zmq.auth reads ZeroMQ's certificate files
        sub.curve_publickey, sub.curve_secretkey = zmq.auth.load_certificate(
            f"{keys}/client.key_secret")
        sub.curve_serverkey, _ = zmq.auth.load_certificate(f"{keys}/server.key")
    sub.connect(endpoint)
    # topics are "<type>/<stream>/": one subscription per event type this client wants
    suffix = f"{stream}/" if stream else ""
    for kind in ("cut", "segments", "closed"):
        sub.setsockopt(zmq.SUBSCRIBE, f"{kind}/{suffix}".encode())
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
