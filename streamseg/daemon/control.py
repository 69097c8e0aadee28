"""The control endpoint (REQ/REP): ping, hello, streams, state, since, logged, stats,
checkpoint, shutdown.

:class:`Control` owns the REP socket, decides who may change the daemon's state, and answers
each request from what a :class:`ControlView` tells it; it knows nothing else of the daemon.
"""

from __future__ import annotations

from typing import Protocol

import msgpack
import zmq

from streamseg import protocol
from streamseg.daemon.state_files import LogReadError
from streamseg.protocol.auth import matches

CHANGING_OPS = protocol.CHANGING_OPS  # ops that change the daemon's state
SINCE_LIMIT = 10000  # events per reply at most; ask again from the last one for more
LOGGED_LIMIT = 10000  # stream ids per `logged` reply at most


class ControlView(Protocol):
    """What the control endpoint asks of the daemon (all on the loop thread)."""

    def listing(self) -> dict:
        """``{"streams": [...open...], "closed": [...]}`` (the ``streams`` op)."""

    def stream_state(self, stream) -> dict | None:
        """The catch-up state of one stream, open, closing or recently closed; None if unknown."""

    def status(self) -> dict:
        """``{"uptime", "totals", "streams"}`` (the ``stats`` op)."""

    def open_ids(self) -> list:
        """Ids of the open streams (for an error naming them)."""

    def hello(self, token: str) -> None:
        """Publish a ``hello`` event carrying ``token``."""

    def checkpoint_now(self) -> int | None:
        """Checkpoint every open stream, on disk when it returns; None if checkpoints are off."""

    def events_since(self, stream: str, seq: int, limit: int) -> dict | None:
        """The ``since`` reply's fields; None without an event log; raises LogReadError."""

    def logged_streams(self, limit: int) -> list | None:
        """``[(stream, first, last)]`` of the streams the event log holds events of; None
        without an event log; raises LogReadError."""

    def stop(self) -> None:
        """Ask the daemon to shut down."""


class Control:
    """The control socket and its replies (docs/protocol.md, Control).

    Parameters
    ----------
    sock : zmq.Socket
        A bound REP socket (its security applied before bind).
    view : ControlView
        The daemon's side.
    curve : bool
        Whether CURVE authenticates every client (then any may change state).
    token, token_file : str or None
        Without CURVE, the token a state-changing request must carry, and where it is kept.
    """

    def __init__(
        self,
        sock: zmq.Socket,
        view: ControlView,
        curve: bool,
        token: str | None = None,
        token_file=None,
    ):
        self.sock, self.view, self.curve = sock, view, curve
        self.token, self.token_file = token, token_file

    def serve(self) -> None:
        """Answer every queued request (REP: one reply per request)."""
        while True:
            try:
                parts = self.sock.recv_multipart(zmq.NOBLOCK, copy=False)
            except zmq.Again:
                return
            try:
                req = msgpack.unpackb(parts[-1].bytes, raw=False)
                reply = self.answer(req, self.may_change(req))
            except Exception as err:  # a bad request gets an error reply, never a crash
                reply = {
                    "ok": False,
                    "error": f"bad request ({type(err).__name__}: {err}); "
                    "send a msgpack map with op (docs/protocol.md)",
                }
            reply["v"] = protocol.PROTOCOL_VERSION
            self.sock.send(msgpack.packb(reply, use_bin_type=True))

    def may_change(self, req) -> bool:
        """Whether a request may use state-changing ops: with CURVE every connected client
        holds an authorised key; without it, the request must carry the control token
        (``auth``), which only the daemon's user can read (:mod:`streamseg.protocol.auth`).
        Loopback is not enough: every local user reaches it."""
        if self.curve:
            return True
        return isinstance(req, dict) and matches(req.get("auth"), self.token)

    def answer(self, req, may_change: bool = True) -> dict:
        """The reply to one control request."""
        view = self.view
        op = req.get("op") if isinstance(req, dict) else None
        if isinstance(req, dict) and req.get("v") != protocol.PROTOCOL_VERSION:
            return {
                "ok": False,
                "error": f"protocol version {req.get('v')!r} is not "
                f"supported: send v={protocol.PROTOCOL_VERSION} "
                "(docs/protocol.md)",
            }
        if op in CHANGING_OPS and not may_change:
            return {
                "ok": False,
                "error": f"{op} is refused: without CURVE it needs the control "
                "token (auth), which streamseg's clients read from "
                f"{self.token_file or 'the token file'} when they "
                "run as the daemon's user (or STREAMSEG_TOKEN)",
            }
        if op == "ping":
            return {"ok": True}
        if op == "hello":
            token = req.get("token")
            if not protocol.valid_stream_id(token):
                return {"ok": False, "error": "hello needs a token: 1-128 of A-Za-z0-9_.:@+=-"}
            view.hello(token)
            return {"ok": True}
        if op == "streams":
            return {"ok": True, **view.listing()}
        if op == "stats":
            return {"ok": True, **view.status()}
        if op == "state":
            state = view.stream_state(req.get("stream"))
            if state is not None:
                return {"ok": True, **state}
            return {
                "ok": False,
                "error": f"no stream {req.get('stream')!r}; open: "
                f"{', '.join(sorted(view.open_ids())[:20]) or 'none'}",
            }
        if op == "since":
            return self._since(req)
        if op == "logged":
            return self._logged()
        if op == "checkpoint":
            n = view.checkpoint_now()
            if n is None:
                return {
                    "ok": False,
                    "error": "checkpoints are off (give --state-dir and a checkpoint_interval > 0)",
                }
            return {"ok": True, "streams": n}
        if op == "shutdown":
            view.stop()
            return {"ok": True}
        return {
            "ok": False,
            "error": f"unknown op {op!r}; expected ping, hello, streams, "
            "state, since, logged, stats, checkpoint or shutdown",
        }

    def _since(self, req) -> dict:
        """The logged events of a stream with sequence numbers above ``seq``."""
        stream, seq = req.get("stream"), req.get("seq", 0)
        limit = req.get("limit", SINCE_LIMIT)
        if not isinstance(stream, str) or type(seq) is not int or seq < 0:
            return {
                "ok": False,
                "error": "since needs stream (str) and seq (int >= 0): the "
                "events with sequence numbers > seq",
            }
        limit = min(limit, SINCE_LIMIT) if type(limit) is int and limit > 0 else SINCE_LIMIT
        try:
            reply = self.view.events_since(stream, seq, limit)
        except LogReadError as err:  # a damaged file: said (reply and `error` event)
            return {"ok": False, "error": str(err)}
        if reply is None:
            return {
                "ok": False,
                "error": "this daemon keeps no event log (start it with --state-dir DIR)",
            }
        return {"ok": True, **reply}

    def _logged(self) -> dict:
        """The stream ids the event log holds events of, with their number ranges
        (docs/protocol.md): a reader of every stream's back (``listen --since N`` without
        ``--stream``) asks ``since`` for each."""
        try:
            rows = self.view.logged_streams(LOGGED_LIMIT)
        except LogReadError as err:
            return {"ok": False, "error": str(err)}
        if rows is None:
            return {
                "ok": False,
                "error": "this daemon keeps no event log (start it with --state-dir DIR)",
            }
        return {
            "ok": True,
            "more": len(rows) == LOGGED_LIMIT,
            "streams": [{"stream": s, "first": a, "last": b} for s, a, b in rows],
        }

    def close(self) -> None:
        self.sock.close()
