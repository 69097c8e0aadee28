"""The daemon's events as an LSL marker stream (``serve --lsl-markers``).

One outlet, type ``Markers``, irregular rate, one string channel: each marker is an event's
JSON (the ``to_json`` form of docs/protocol.md) for ``cut``, ``confirm``, ``withdraw``,
``segments``, ``rep`` and ``closed`` events, stamped with the LSL time of the frame it
concerns (a cut's frame, a repetition's or a relabel's first frame, a closed stream's end).
LabRecorder records it beside the mocap, on the same clock.

The frame's time is the sender's clock at that frame (``t0 + frame / fps``, see the
protocol): LSL time already for streams fed by :mod:`streamseg.lsl.bridge`; a Unix time
(``streamseg replay``) is moved onto LSL's clock; any other clock is replaced by the LSL
time at which the daemon published the event.
"""

from __future__ import annotations

import logging
import threading
import time

import zmq

from streamseg import protocol, strict_json
from streamseg.lsl import pylsl

log = logging.getLogger("streamseg.lsl")

KINDS = ("cut", "confirm", "withdraw", "segments", "rep", "closed")
_DAY = 86400.0


def concerned_frame(ev) -> int | None:
    """The stream frame an event is about."""
    if ev.type in ("cut", "confirm", "withdraw"):
        return ev.frame
    if ev.type in ("segments", "rep"):
        return ev.start
    if ev.type == "closed":
        return ev.frames
    return None


def to_lsl_clock(t: float, lsl_now: float, unix_now: float) -> float | None:
    """A sender time on LSL's clock: as is when it is LSL time, moved when it is Unix time,
    None when it is neither (within a day of now)."""
    if abs(t - lsl_now) < _DAY:
        return t
    if abs(t - unix_now) < _DAY:
        return t - unix_now + lsl_now
    return None


class MarkerOutlet:
    """Subscribe to a daemon's events and push them to an LSL marker outlet.

    Parameters
    ----------
    publish, control : str
        The daemon's endpoints.
    time_of : callable(stream, frame) -> float or None, optional
        The sender's time of a stream's frame (the daemon's ``StreamState.time_of``; None
        for a stream it does not hold); without it a cut or repetition is stamped with its
        event ``time`` and other events with the time they were published.
    name, source_id : str
        Of the LSL stream.
    curve : ClientKeys or None
    """

    def __init__(
        self,
        publish: str,
        control: str,
        time_of=None,
        name: str = "streamseg",
        source_id: str | None = None,
        curve=None,
        ctx=None,
    ):
        lsl = pylsl()
        self.publish, self.control = publish, control
        self.time_of = time_of
        self.curve = curve
        self.ctx = ctx or zmq.Context.instance()
        info = lsl.StreamInfo(
            name,
            "Markers",
            1,
            lsl.IRREGULAR_RATE,
            lsl.cf_string,
            source_id or f"streamseg-events-{publish}",
        )
        info.desc().append_child_value("manufacturer", "streamseg")
        info.desc().append_child("channels").append_child("channel").append_child_value(
            "label", "event"
        ).parent().append_child_value("type", "Marker")
        self.outlet = lsl.StreamOutlet(info)
        self._clock = lsl.local_clock
        self.clocks: dict = {}  # stream -> (time of frame 0, seconds per frame)
        self.pushed = 0
        self.stopping = threading.Event()
        self.ready = threading.Event()
        self.thread = None

    def start(self) -> MarkerOutlet:
        self.thread = threading.Thread(target=self.run, daemon=True, name="lsl-markers")
        self.thread.start()
        return self

    def stop(self, timeout: float = 5.0) -> None:
        self.stopping.set()
        if self.thread is not None:
            self.thread.join(timeout)

    def stamp(self, ev) -> float:
        """The LSL time of the frame ``ev`` concerns."""
        now_lsl, now_unix = self._clock(), time.time()
        frame = concerned_frame(ev)
        t = None
        if frame is not None and self.time_of is not None:
            t0 = self.time_of(ev.stream, 0)
            if t0 is not None:  # kept: a closed stream is gone from the daemon
                self.clocks[ev.stream] = (t0, self.time_of(ev.stream, 1) - t0)
            if ev.stream in self.clocks:
                t0, dt = self.clocks[ev.stream]
                t = t0 + frame * dt
        if t is None and ev.type in ("cut", "confirm", "withdraw", "rep"):
            t = ev.time
        stamped = None if t is None else to_lsl_clock(t, now_lsl, now_unix)
        return now_lsl if stamped is None else stamped

    def push(self, ev) -> None:
        self.outlet.push_sample([strict_json.dumps(protocol.to_json(ev))], self.stamp(ev))
        self.pushed += 1

    def run(self) -> None:
        from streamseg.client import listen, subscribe

        sub = subscribe(self.publish, self.control, ctx=self.ctx, curve=self.curve)
        self.ready.set()
        try:
            while not self.stopping.is_set():
                try:
                    for ev in listen(sub, timeout=0.5):
                        if ev.type in KINDS:
                            self.push(ev)
                        if self.stopping.is_set():
                            break
                except TimeoutError:
                    continue
        except zmq.ZMQError as err:  # the context was terminated: the daemon stopped
            log.info("marker outlet stopped: %s", err)
        finally:
            sub.close()
