"""The order of a stream id's events across its takes (docs/protocol.md, order of a stream's
events).

A stream id may be announced again while its older take still awaits its final relabel.
Every take's events must come out after the older take's ``closed``: while an older take is
open, a newer take's events are held here, unnumbered, and released in order once the older
take's ``closed`` is out.
"""

from __future__ import annotations

from typing import NamedTuple


class Take(NamedTuple):
    """One take of a stream id in line: its generation, its state, its held events."""

    gen: int
    state: object  # streams.StreamState (None once only its events matter)
    held: list  # [(state, event)] waiting to be numbered


class TakeOrder:
    """Per stream id with more than one take in line: the takes, oldest first."""

    def __init__(self):
        self._lines: dict[str, list[Take]] = {}

    def __bool__(self) -> bool:
        return bool(self._lines)

    def opened(self, st, older: list) -> None:
        """A take ``st`` opens; ``older``: ``[(gen, state)]`` of the takes of its id still
        awaiting their final relabel (oldest first)."""
        line = self._lines.get(st.stream)
        if line is None and older:
            line = self._lines[st.stream] = [Take(g, s, []) for g, s in older]
        if line is not None:
            line.append(Take(st.gen, st, []))

    def waits(self, stream: str, gen: int) -> bool:
        """Whether take ``gen`` of ``stream`` is behind an older one (its events held)."""
        line = self._lines.get(stream)
        return bool(line) and line[0].gen != gen

    def hold(self, st, ev) -> bool:
        """Hold ``ev`` if its take is behind an older one; True when held. An event without a
        take (``st`` None) belongs to the newest take of its id."""
        line = self._lines.get(ev.stream) if ev.type != "stats" else None
        if line is None:
            return False
        gen = st.gen if st is not None else line[-1].gen
        if gen == line[0].gen:
            return False
        for take in line:
            if take.gen == gen:
                take.held.append((st, ev))
                return True
        return False

    def closed(self, st, send, first_seq, still_closing: bool) -> None:
        """``closed`` of ``st`` is out: the next takes of its id publish what they held,
        through ``send(state, event) -> numbered event``. ``first_seq()``: the id's last
        event number now (where the next take's history starts); ``still_closing``: an older
        take of this id still awaits its final relabel."""
        line = self._lines.get(st.stream)
        if not line or line[0].gen != st.gen:
            return
        line.pop(0)
        while line:
            nxt = line[0]
            if nxt.state is not None:  # its history starts after the older take's closed
                nxt.state.seq_base = first_seq()
            done = False
            for hst, hev in nxt.held:
                numbered = send(hst, hev)
                if hst is not None:  # the late joiners' copies get their numbers too
                    if hst.segments is hev:
                        hst.segments = numbered
                    for i, c in enumerate(hst.cuts):
                        if c is hev:
                            hst.cuts[i] = numbered
                done = done or hev.type == "closed"
            nxt.held.clear()
            if not done:
                break
            line.pop(0)
        if len(line) <= 1 and not still_closing:
            del self._lines[st.stream]
