"""The control endpoint's requests (REQ/REP): ping, hello, streams, state, since, logged,
stats, checkpoint, shutdown."""

from __future__ import annotations

import time

import msgpack
import zmq

from streamseg import protocol
from streamseg.daemon.eventlog import LogReadError
from streamseg.protocol.auth import matches


def serve_control(daemon) -> None:
    """Answer every queued control request (REP: one reply per request)."""
    while True:
        try:
            parts = daemon.control.recv_multipart(zmq.NOBLOCK, copy=False)
        except zmq.Again:
            return
        try:
            req = msgpack.unpackb(parts[-1].bytes, raw=False)
            reply = answer(daemon, req, may_change(daemon, req))
        except Exception as err:  # a bad request gets an error reply, never a crash
            reply = {"ok": False, "error": f"bad request ({type(err).__name__}: {err}); "
                                          "send a msgpack map with op (docs/protocol.md)"}
        reply["v"] = protocol.PROTOCOL_VERSION
        daemon.control.send(msgpack.packb(reply, use_bin_type=True))


CHANGING_OPS = protocol.CHANGING_OPS  # ops that change the daemon's state


def may_change(daemon, req) -> bool:
    """Whether a request may use state-changing ops: with CURVE every connected client holds
    an authorised key; without it, the request must carry the control token (``auth``), which
    only the daemon's user can read (:mod:`streamseg.protocol.auth`). Loopback is not enough:
    every local user reaches it."""
    if daemon.security is not None:
        return True
    return isinstance(req, dict) and matches(req.get("auth"), daemon.token)


def answer(daemon, req, may_change: bool = True) -> dict:
    """The reply to one control request (docs/protocol.md, Control)."""
    op = req.get("op") if isinstance(req, dict) else None
    if isinstance(req, dict) and req.get("v") != protocol.PROTOCOL_VERSION:
        return {"ok": False, "error": f"protocol version {req.get('v')!r} is not supported: "
                                      f"send v={protocol.PROTOCOL_VERSION} (docs/protocol.md)"}
    if op in CHANGING_OPS and not may_change:
        return {"ok": False, "error": f"{op} is refused: without CURVE it needs the control "
                                      "token (auth), which streamseg's clients read from "
                                      f"{daemon.token_file or 'the token file'} when they run "
                                      "as the daemon's user (or STREAMSEG_TOKEN)"}
    if op == "ping":
        return {"ok": True}
    if op == "hello":
        token = req.get("token")
        if not protocol.valid_stream_id(token):
            return {"ok": False, "error": "hello needs a token: 1-128 of A-Za-z0-9_.:@+=-"}
        daemon.pub.send_multipart(protocol.encode(protocol.Hello(token)))
        return {"ok": True}
    if op == "streams":
        # closed ones too (those `state` still answers for, oldest first): a client that
        # joins after a stream ended (the view beside a daemon) can still list it
        closed = [{"stream": s, "closed": cs.get("closed"), "frame": cs.get("frame")}
                  for s, cs in daemon.closed_states.items() if s not in daemon.streams]
        return {"ok": True, "streams": [{"stream": s, "fps": st.fps, "frame": st.next_seq,
                                         "revision": st.revision}
                                        for s, st in daemon.streams.items()],
                "closed": closed}
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
    if op == "since":
        return since(daemon, req)
    if op == "logged":
        return logged(daemon)
    if op == "checkpoint":
        if daemon.checkpoints is None:
            return {"ok": False, "error": "checkpoints are off (give --state-dir and a "
                                          "checkpoint_interval > 0)"}
        daemon.checkpoints.wait()
        n = daemon.rounds.all_now(daemon.streams)
        daemon.checkpoints.wait()  # the reply says it is on disk
        return {"ok": True, "streams": n}
    if op == "shutdown":
        daemon.stop()
        return {"ok": True}
    return {"ok": False, "error": f"unknown op {op!r}; expected ping, hello, streams, state, "
                                  "since, logged, stats, checkpoint or shutdown"}


SINCE_LIMIT = 10000  # events per reply at most; ask again from the last one for more


def since(daemon, req) -> dict:
    """The logged events of a stream with sequence numbers above ``seq`` (docs/protocol.md)."""
    stream, seq = req.get("stream"), req.get("seq", 0)
    limit = req.get("limit", SINCE_LIMIT)
    if not isinstance(stream, str) or type(seq) is not int or seq < 0:
        return {"ok": False, "error": "since needs stream (str) and seq (int >= 0): the events "
                                      "with sequence numbers > seq"}
    if daemon.eventlog is None:
        return {"ok": False, "error": "this daemon keeps no event log (start it with "
                                      "--state-dir DIR)"}
    limit = min(limit, SINCE_LIMIT) if type(limit) is int and limit > 0 else SINCE_LIMIT
    try:
        bodies, first = daemon.eventlog.since(stream, seq, limit)
        last = daemon.eventlog.logged_seq(stream)
        skipped = daemon.eventlog.skipped(stream, seq)
    except LogReadError as err:  # a damaged file: said (reply and `error` event), not "bad"
        daemon._report_storage()
        return {"ok": False, "error": str(err)}
    events = [msgpack.unpackb(b, raw=False) for b in bodies]
    return {"ok": True, "stream": stream, "events": events, "first": first, "last": last,
            "skipped": skipped, "more": len(events) == limit}


LOGGED_LIMIT = 10000  # stream ids per `logged` reply at most


def logged(daemon) -> dict:
    """The stream ids the event log holds events of, with their number ranges
    (docs/protocol.md): a reader of every stream's back (``listen --since N`` without
    ``--stream``) asks ``since`` for each."""
    if daemon.eventlog is None:
        return {"ok": False, "error": "this daemon keeps no event log (start it with "
                                      "--state-dir DIR)"}
    try:
        rows = daemon.eventlog.streams(LOGGED_LIMIT)
    except LogReadError as err:
        daemon._report_storage()
        return {"ok": False, "error": str(err)}
    return {"ok": True, "streams": [{"stream": s, "first": a, "last": b} for s, a, b in rows],
            "more": len(rows) == LOGGED_LIMIT}
