"""What the daemon's event log gives back (control op ``since``), and a stream's events
split into its takes."""

from __future__ import annotations

from streamseg import protocol
from streamseg.client.control import request


def takes(events) -> list:
    """A stream id's events split into its takes at each ``closed``, in the order given (a
    re-announced id's new take follows its old one's ``closed``); the last, still open take
    (no ``closed`` yet) too."""
    out, cur = [], []
    for e in events:
        cur.append(e)
        if e.type == "closed":
            out.append(cur)
            cur = []
    return out + ([cur] if cur else [])


def fetch_since(
    endpoint: str,
    stream: str,
    seq: int,
    ctx=None,
    upto=None,
    curve=None,
    on_range=None,
    skipped=None,
) -> list:
    """The logged events of ``stream`` with sequence numbers in ``(seq, upto)`` (all after
    ``seq`` when ``upto`` is None) from the control op ``since``, page by page; raises
    LookupError when the daemon keeps no log. ``on_range(first, last)`` is called with the
    first reply's lowest number held and the stream's newest one; ``skipped``, a list, gets
    the ranges ``[lo, hi]`` of numbers above ``seq`` the daemon skipped at a restart."""
    out = []
    while True:
        reply = request(endpoint, "since", ctx, curve=curve, stream=stream, seq=seq)
        if not reply.get("ok"):
            raise LookupError(reply.get("error"))
        if skipped is not None:
            skipped += [r for r in reply.get("skipped", []) if r not in skipped]
        if on_range is not None:
            on_range(reply.get("first") or 0, reply.get("last") or 0)
            on_range = None
        for body in reply["events"]:
            ev = protocol.from_body(body)
            if upto is not None and ev.seq >= upto:
                return out
            out.append(ev)
            seq = ev.seq
        if not reply.get("more"):
            return out


def count_in(ranges, lo: int, hi: int) -> int:
    """How many of the numbers ``lo..hi`` (inclusive) lie in the ranges ``[[a, b], ...]``."""
    return sum(max(0, min(b, hi) - max(a, lo) + 1) for a, b in ranges)
