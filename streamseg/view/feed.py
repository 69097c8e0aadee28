"""The view's side of the daemon: a SUB socket for events and a REQ socket for snapshots.

Late join (docs/protocol.md, "Late joiners"): subscribe, then ask ``state`` of each stream,
apply snapshot and events in whatever order they come (the :class:`~streamseg.view.model.Hub`
merges idempotently). A stream's snapshot is asked for when the view first hears of it, and
every known stream's again once the first event proves the subscription is live (a snapshot
taken before that could miss events published in between). ``stats`` is polled over control,
so rates and buffer fill show whatever the daemon's heartbeat setting.
"""

from __future__ import annotations

import asyncio
import logging

import msgpack
import zmq
import zmq.asyncio

from streamseg import protocol

log = logging.getLogger("streamseg.view")


class Feed:
    """Keeps a :class:`~streamseg.view.model.Hub` in step with a daemon.

    Parameters
    ----------
    hub : Hub
    publish : str
        The daemon's publish endpoint.
    control : str, optional
        Its control endpoint (snapshots, stats); without it the view shows only what it
        hears after it started.
    poll : float
        Seconds between ``stats`` requests (rates, buffer fill, stream discovery).
    labels : bool
        Read the human label files that replays announce.
    curve : ClientKeys, optional
        CURVE keys (:class:`streamseg.daemon.security.ClientKeys`) for a daemon that has
        them on; the page itself still has no authentication (loopback).
    """

    def __init__(
        self,
        hub,
        publish: str,
        control: str | None = None,
        poll: float = 1.0,
        labels: bool = True,
        timeout: float = 5.0,
        curve=None,
    ):
        self.hub = hub
        self.curve = curve
        self.publish = publish
        self.control = control
        self.poll = poll
        self.labels = labels
        self.timeout = timeout
        self.ctx = zmq.asyncio.Context()
        self.live = asyncio.Event()  # set at the first event: the subscription works
        self.connected = None  # None: not asked yet; True/False: control answered or not
        self.reachable = False  # the publisher's connection stands (the SUB socket's monitor)
        self.changed = asyncio.Event()  # the hub has dirty streams
        self.wanted = asyncio.Event()  # the hub wants a snapshot
        self.check: set = set()  # open streams the daemon's stats did not list
        self.listed = False  # the daemon's closed streams asked for (once it answers)
        self._req = None
        self._tasks: list = []

    async def start(self) -> None:
        self.sub = self.ctx.socket(zmq.SUB)
        self.sub.setsockopt(zmq.LINGER, 0)
        self.sub.setsockopt(zmq.RCVHWM, 0)  # the view must not lose events to its own pace
        self.sub.setsockopt(zmq.SUBSCRIBE, b"")
        if self.curve is not None:
            self.curve.apply(self.sub)
        # watched from before the connection starts: is a daemon there at all?
        self._monitor = self.sub.get_monitor_socket(
            zmq.EVENT_HANDSHAKE_SUCCEEDED | zmq.EVENT_DISCONNECTED
        )
        self.sub.connect(self.publish)
        self._tasks = [
            asyncio.create_task(self._events(), name="view-events"),
            asyncio.create_task(self._watch(), name="view-watch"),
        ]
        if self.control:
            self._tasks.append(asyncio.create_task(self._snapshots(), name="view-control"))

    async def stop(self) -> None:
        for t in self._tasks:
            t.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        if hasattr(self, "sub"):  # (a feed that never started has none)
            self.sub.disable_monitor()
            self._monitor.close(linger=0)
            self.sub.close()
        if self._req is not None:
            self._req.close()
        self.ctx.term()

    async def _events(self) -> None:
        recv, apply = self.sub.recv_multipart, self.hub.apply
        n = 0
        while True:
            parts = await recv()
            n += 1
            if n % 128 == 0:  # a ready future does not yield: let the pages have their turn
                await asyncio.sleep(0)
            try:
                ev = protocol.decode(parts)
            except protocol.WireError as err:
                log.warning("undecodable event skipped: %s", err)
                continue
            try:
                apply(ev)
            except Exception:  # never stop listening over one event
                log.exception("event %s not applied", ev.type)
            if not self.live.is_set():
                self.live.set()
                self.hub.want_state.update(self.hub.streams)
            if self.hub.want_state:
                self.wanted.set()
            self.changed.set()

    @property
    def daemon_ok(self) -> bool:
        """Whether the daemon is there: its publisher connected and, with a control endpoint,
        its last control request answered."""
        return self.reachable and self.connected is not False

    async def _watch(self) -> None:
        from zmq.utils.monitor import parse_monitor_message

        while True:
            event = parse_monitor_message(await self._monitor.recv_multipart())["event"]
            reachable = event == zmq.EVENT_HANDSHAKE_SUCCEEDED
            if reachable != self.reachable:
                self.reachable = reachable
                self.changed.set()  # the pages' header says so at the next tick

    async def request(self, op: str, **fields) -> dict | None:
        """One control request; None when the daemon does not answer in ``timeout``."""
        if self._req is None:
            self._req = self.ctx.socket(zmq.REQ)
            self._req.setsockopt(zmq.LINGER, 0)
            if self.curve is not None:
                self.curve.apply(self._req)
            self._req.connect(self.control)
        try:
            await self._req.send(
                msgpack.packb({"v": protocol.PROTOCOL_VERSION, "op": op, **fields})
            )
            reply = msgpack.unpackb(
                await asyncio.wait_for(self._req.recv(), self.timeout), raw=False
            )
        except (asyncio.TimeoutError, zmq.ZMQError):
            self._req.close()  # a REQ socket that lost its reply cannot send again
            self._req = None
            self.connected = False
            return None
        self.connected = True
        return reply

    async def _snapshots(self) -> None:
        loop = asyncio.get_running_loop()
        next_poll = 0.0
        while True:
            if loop.time() >= next_poll:
                next_poll = loop.time() + self.poll
                if not self.listed:  # streams that closed before the view joined
                    listed = await self.request("streams")
                    if listed and listed.get("ok"):
                        self.listed = True
                        self.hub.want_state.update(
                            c["stream"]
                            for c in listed.get("closed") or []
                            if isinstance(c, dict)
                            and isinstance(c.get("stream"), str)
                            and c["stream"] not in self.hub.streams
                        )
                stats = await self.request("stats")
                if stats and stats.get("ok"):
                    self.hub.apply(
                        protocol.Stats(float(stats["uptime"]), stats["totals"], stats["streams"])
                    )
                    self.hub.applied -= 1  # a polled snapshot, not a forwarded event
                    # open here, unknown to the daemon's table: closing, or lost in a crash
                    self.check.update(
                        s
                        for s, sv in self.hub.streams.items()
                        if sv.closed is None and s not in stats["streams"]
                    )
                    self.hub.want_state.update(self.check)
                    self.changed.set()
            self.wanted.clear()
            while self.hub.want_state:
                stream = min(self.hub.want_state)
                self.hub.want_state.discard(stream)
                reply = await self.request("state", stream=stream)
                if reply is not None and self.check:
                    if not reply.get("ok") and stream in self.check:
                        self.hub.lost(stream)  # the daemon restarted without it
                        self.changed.set()
                    self.check.discard(stream)
                if reply and reply.get("ok"):
                    if not self.labels:
                        reply.pop("labels", None)
                    try:
                        self.hub.apply_state(reply)
                    except Exception:  # a snapshot the view cannot read must not stop it
                        log.exception("state of stream %s not applied", stream)
                    self.changed.set()
            if self.hub.want_state:
                continue  # discovered by the stats just applied
            try:  # wake early when a new stream shows up in the events
                await asyncio.wait_for(self.wanted.wait(), max(0.0, next_poll - loop.time()))
            except asyncio.TimeoutError:
                pass
