"""What any process needs to follow the daemon: pyzmq and msgpack, nothing of streamseg.

    python clients/python/listener.py tcp://127.0.0.1:5561 [STREAM] [--max N]
        [--control tcp://127.0.0.1:5562] [--keys DIR]

Prints one line per cut and relabel (protocol v1, docs/protocol.md) until the stream closes
(or N events). A daemon with the two-stage cut decision (``early_delay_s``) sends some cuts
``pending``; a later ``withdraw`` takes one back (it leaves the list of cuts printed at the
close) and a ``confirm`` says it stands. With --control it first makes sure its subscription
is live (the hello handshake, docs/protocol.md), so it misses nothing published after
"listening on"; and it follows every event of the stream (each type; the other types get a
line "STREAM: TYPE event N"), so the event numbers (``seq``, per stream) show a loss: the
missing events are fetched from the daemon's event log (control op ``since``), printed in
their place and reported on stderr, as ``streamseg listen --control`` does; the ``stats``
heartbeats' ``last_seq`` show a loss at a stream's end. With ``--keys DIR`` (made by
``streamseg keys DIR``) it connects with CURVE: its pair from ``client.key_secret``, the
daemon's public key from ``server.key``. A template for clients in other processes or
languages.
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
    del argv[i : i + 2]
    return value


def use_keys(sock, keys):
    """CURVE on ``sock``: zmq.auth reads ZeroMQ's certificate files made by streamseg keys."""
    try:
        sock.curve_publickey, sock.curve_secretkey = zmq.auth.load_certificate(
            f"{keys}/client.key_secret"
        )
        sock.curve_serverkey, _ = zmq.auth.load_certificate(f"{keys}/server.key")
    except (OSError, ValueError) as err:  # one line, not a traceback
        print(f"--keys {keys}: {err}: make the keys with `streamseg keys DIR`", file=sys.stderr)
        sys.exit(2)


def handshake(sub, control, keys=None):
    """Ask the daemon to publish a random token until it arrives: the subscription is live.
    Returns the control REQ socket, kept for ``since`` requests."""
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
    sub.setsockopt(zmq.UNSUBSCRIBE, topic)
    return req


def since(req, stream, after, upto=None):
    """The events of ``stream`` numbered after ``after`` and below ``upto`` (None: all), from
    the event log (control op ``since``, page by page); raises RuntimeError with the
    daemon's error."""
    out = []
    while True:
        req.send(msgpack.packb({"v": 1, "op": "since", "stream": stream, "seq": after}))
        reply = msgpack.unpackb(req.recv(), raw=False)
        if not reply.get("ok"):
            raise RuntimeError(reply.get("error"))
        for ev in reply["events"]:
            if upto is not None and ev["seq"] >= upto:
                return out
            out.append(ev)
            after = ev["seq"]
        if not reply.get("more"):
            return out


def on_hole(req, key, first, end):
    """Events ``first..end - 1`` of ``key`` were missed: fetched (with a control socket, and
    not daemon-wide ones: those the subscription may not all hold) and said on stderr."""
    where = f"events {first}..{end - 1} of stream {key}"
    if req is None or key == "*":
        print(
            f"hole: {where} were missed ({end - first})"
            f"{'' if req else '; give --control to fetch them'}",
            file=sys.stderr,
        )
        return []
    try:
        evs = since(req, key, first - 1, end)
    except RuntimeError as err:
        print(f"hole: {where} were missed; cannot fetch them: {err}", file=sys.stderr)
        return []
    print(f"hole: {where}: {len(evs)} fetched from the event log", file=sys.stderr)
    return evs


class Printer:
    """Prints events (one line each, ``stats`` and ``hello`` none); keeps each stream's cuts,
    withdrawn ones removed, for the final list of a stream that had a pending cut."""

    def __init__(self, stream):
        self.stream, self.seen, self.done = stream, 0, False
        self.cuts = {}  # stream -> its cut frames, withdrawn ones removed
        self.two_stage = set()  # streams that sent a pending cut: their final list is printed

    def show(self, ev):
        kind, sid = ev["type"], ev.get("stream")
        if kind in ("stats", "hello"):
            return
        self.seen += 1
        if kind == "cut":
            self.cuts.setdefault(sid, []).append(ev["frame"])
            pending = ev.get("pending", False)  # optional field: absent means final
            if pending:
                self.two_stage.add(sid)
            print(
                f"{sid}: cut at frame {ev['frame']} (decided at {ev['emitted_at']}"
                f"{', pending' if pending else ''})",
                flush=True,
            )
        elif kind == "withdraw":
            frames = self.cuts.get(sid, [])
            if ev["frame"] in frames:
                frames.remove(ev["frame"])
            print(
                f"{sid}: withdraw of the cut at frame {ev['frame']} (at {ev['emitted_at']})",
                flush=True,
            )
        elif kind == "segments":
            runs = ", ".join(f"{a}-{b}:{lab}" for a, b, lab in ev["segments"])
            print(
                f"{sid}: relabel {ev['revision']} of {ev['start']}-{ev['end']}: {runs}", flush=True
            )
        elif kind == "closed":
            final = self.cuts.pop(sid, [])
            if sid in self.two_stage:
                print(f"{sid}: final cuts {sorted(final)}")
            print(f"{sid}: closed ({ev['reason']})", flush=True)
            if self.stream and sid == self.stream:
                self.done = True
        else:  # confirm, rep, gap, error: followed for their numbers
            print(f"{sid if sid is not None else '*'}: {kind} event {ev.get('seq')}", flush=True)


def main(argv):
    args = list(argv)
    limit = option(args, "--max")
    limit = int(limit) if limit is not None else None
    control = option(args, "--control")
    keys = option(args, "--keys")
    endpoint, stream = args[0], (args[1] if len(args) > 1 else "")
    sub = zmq.Context.instance().socket(zmq.SUB)
    sub.setsockopt(zmq.RCVHWM, 0)  # no loss to this process's own slowness
    if keys:
        use_keys(sub, keys)
    sub.connect(endpoint)
    # topics are "<type>/<stream>/": with --control every type of the stream (its numbers
    # must show a loss) and the heartbeats (a loss at its end); without, the four printed
    suffix = f"{stream}/" if stream else ""
    kinds = ["cut", "withdraw", "segments", "closed"]
    if control and not stream:
        sub.setsockopt(zmq.SUBSCRIBE, b"")
    else:
        for kind in kinds + (["confirm", "rep", "gap", "error"] if control else []):
            sub.setsockopt(zmq.SUBSCRIBE, f"{kind}/{suffix}".encode())
        if control:
            sub.setsockopt(zmq.SUBSCRIBE, b"stats/")
    req = handshake(sub, control, keys) if control else None
    print(f"listening on {endpoint}", flush=True)
    out = Printer(stream)
    last = {}  # stream id ("*": daemon-wide) -> last event number printed
    while not out.done and (limit is None or out.seen < limit):
        topic, body = sub.recv_multipart()
        ev = msgpack.unpackb(body, raw=False)
        if ev.get("v") != 1:
            print(f"skipping protocol version {ev.get('v')}", file=sys.stderr)
            continue
        if req is not None and ev["type"] == "stats":  # a loss at a stream's tail
            for key, newest in (ev.get("last_seq") or {}).items():
                prev = last.get(key)
                if prev is not None and newest > prev and (not stream or key == stream):
                    for e in on_hole(req, key, prev + 1, newest + 1):
                        if not out.done:
                            out.show(e)
                    last[key] = newest
            continue
        n = ev.get("seq")
        if n is not None:
            key = ev.get("stream") if ev.get("stream") is not None else "*"
            prev = last.get(key)
            if prev is not None and n <= prev:
                continue  # printed already, from the log
            if prev is not None and n > prev + 1:
                for e in on_hole(req, key, prev + 1, n):
                    if not out.done:
                        out.show(e)
            last[key] = n
            if out.done:
                break
        out.show(ev)
    if req is not None:
        req.close()
    sub.close(linger=0)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
