"""What any process needs to follow the daemon: pyzmq and msgpack, nothing of streamseg.

    python clients/minimal_listener.py tcp://127.0.0.1:5561 [STREAM] [--max N]

Prints one line per cut and relabel (protocol v1, docs/protocol.md) until the stream closes
(or N events). A template for clients in other processes or languages.
"""

import sys

import msgpack
import zmq


def main(argv):
    args = [a for a in argv if not a.startswith("--max")]
    limit = int(argv[argv.index("--max") + 1]) if "--max" in argv else None
    if limit is not None:
        args.remove(str(limit))
    endpoint, stream = args[0], (args[1] if len(args) > 1 else "")
    sub = zmq.Context.instance().socket(zmq.SUB)
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
