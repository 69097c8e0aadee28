"""The control endpoint's requests (REQ/REP): ping, hello, streams, state, stats, shutdown."""

from __future__ import annotations

import time

import msgpack
import zmq

from streamseg import protocol


def serve_control(daemon) -> None:
    """Answer every queued control request (REP: one reply per request)."""
    while True:
        try:
            parts = daemon.control.recv_multipart(zmq.NOBLOCK)
        except zmq.Again:
            return
        try:
            reply = answer(daemon, msgpack.unpackb(parts[-1], raw=False))
        except Exception as err:  # a bad request gets an error reply, never a crash
            reply = {"ok": False, "error": f"bad request ({type(err).__name__}: {err}); "
                                          "send a msgpack map with op (docs/protocol.md)"}
        reply["v"] = protocol.PROTOCOL_VERSION
        daemon.control.send(msgpack.packb(reply, use_bin_type=True))


def answer(daemon, req) -> dict:
    """The reply to one control request (docs/protocol.md, Control)."""
    op = req.get("op") if isinstance(req, dict) else None
    if isinstance(req, dict) and req.get("v") != protocol.PROTOCOL_VERSION:
        return {"ok": False, "error": f"protocol version {req.get('v')!r} is not supported: "
                                      f"send v={protocol.PROTOCOL_VERSION} (docs/protocol.md)"}
    if op == "ping":
        return {"ok": True}
    if op == "hello":
        token = req.get("token")
        if not protocol.valid_stream_id(token):
            return {"ok": False, "error": "hello needs a token: 1-128 of A-Za-z0-9_.:@+=-"}
        daemon.pub.send_multipart(protocol.encode(protocol.Hello(token)))
        return {"ok": True}
    if op == "streams":
        return {"ok": True, "streams": [{"stream": s, "fps": st.fps, "frame": st.next_seq,
                                         "revision": st.revision}
                                        for s, st in daemon.streams.items()]}
    if op == "stats":
        return {"ok": True, "uptime": time.monotonic() - daemon._started,
                "totals": daemon._totals(),
                "streams": {s: st.stats() for s, st in daemon.streams.items()}}
    if op == "state":
        stream = req.get("stream")
        st = daemon.streams.get(stream)
        if st is not None:
            return {"ok": True, **st.state()}
        for (s, _), (cst, reason) in daemon.closing.items():
            if s == stream:
                return {"ok": True, **cst.state(), "closed": reason}
        if stream in daemon.closed_states:
            return {"ok": True, **daemon.closed_states[stream]}
        return {"ok": False, "error": f"no stream {stream!r}; open: "
                                      f"{', '.join(sorted(daemon.streams)[:20]) or 'none'}"}
    if op == "shutdown":
        daemon.stop()
        return {"ok": True}
    return {"ok": False, "error": f"unknown op {op!r}; expected ping, hello, streams, state, "
                                  "stats or shutdown"}
