"""The view's web server (aiohttp): the static page, a WebSocket of coalesced updates, JSON.

Routes: ``/`` the page, ``/static/*`` its script and style, ``/ws`` the update stream,
``/api/streams`` every stream's list row, ``/api/stream/{id}`` one stream's whole timeline.

Updates are coalesced: the hub marks streams that changed; every ``interval`` seconds each
page gets one ``rows`` message with the changed streams' rows (not one message per event)
and, for the one stream it has open, one ``timeline`` delta (new cuts and repetitions since
its cursors, the segments when a relabel changed them). So a page's cost follows the number
of streams that changed and what it shows, not the daemon's event rate.
"""

from __future__ import annotations

import asyncio
import ipaddress
import json
import logging
import threading
from pathlib import Path
from urllib.parse import urlsplit

from aiohttp import WSMsgType, web

from streamseg import strict_json
from streamseg.view.feed import Feed
from streamseg.view.model import Hub

log = logging.getLogger("streamseg.view")
STATIC = Path(__file__).resolve().parent / "static"
LOOPBACK_NAMES = {"127.0.0.1", "localhost", "::1"}


def _loopback(host: str) -> bool:
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return host == "localhost"


class _Page:
    """One connected page: its socket and what it has of its open stream."""

    __slots__ = (
        "ws",
        "stream",
        "cut_next",
        "rep_next",
        "seg_version",
        "has_human",
        "sent",
        "cut_version",
    )

    def __init__(self, ws):
        self.ws = ws
        self.stream = None
        self.cut_next = self.rep_next = 0
        self.seg_version = -1
        self.has_human = False
        self.sent = 0
        self.cut_version = 0


class ViewServer:
    """The live view of one daemon.

    Parameters
    ----------
    publish, control : str
        The daemon's publish and control endpoints (control optional, see :class:`Feed`).
    host, port : str, int
        HTTP address; loopback by default (the page has no authentication), port 0: any
        free port.
    interval : float
        Seconds between coalesced page updates.
    curve : ClientKeys, optional
        CURVE keys for a daemon that has them on (see :class:`Feed`).
    """

    def __init__(
        self,
        publish: str,
        control: str | None = None,
        host: str = "127.0.0.1",
        port: int = 0,
        interval: float = 0.1,
        poll: float = 1.0,
        labels: bool = True,
        curve=None,
    ):
        self.publish, self.control = publish, control
        self.host, self.port = host, port
        self.interval = interval
        self.hub = Hub()
        self.feed = Feed(self.hub, publish, control, poll=poll, labels=labels, curve=curve)
        self.pages: set = set()
        self.url = None
        self.sent = 0  # messages sent to pages
        self._runner = None
        self._pump = None

    def app(self) -> web.Application:
        app = web.Application(middlewares=[self._check_host])
        app.router.add_get("/", self._index)
        app.router.add_get("/ws", self._ws)
        app.router.add_get("/api/streams", self._api_streams)
        app.router.add_get("/api/stream/{stream}", self._api_stream)
        app.router.add_static("/static", STATIC)
        return app

    async def start(self) -> str:
        """Connect to the daemon, bind the HTTP socket; returns the page's address. On a
        failure (e.g. the address in use) what was started is stopped before it is raised,
        so no task is left pending on a loop that closes."""
        try:
            await self.feed.start()
            self._runner = web.AppRunner(self.app(), access_log=None)
            await self._runner.setup()
            site = web.TCPSite(self._runner, self.host, self.port)
            await site.start()
        except BaseException:
            await self.stop()
            raise
        sock = site._server.sockets[0]  # the bound port when port was 0
        host, port = sock.getsockname()[:2]
        self.url = f"http://{host if ':' not in host else f'[{host}]'}:{port}/"
        self._pump = asyncio.create_task(self._broadcast(), name="view-broadcast")
        return self.url

    async def stop(self) -> None:
        if self._pump is not None:
            self._pump.cancel()
            await asyncio.gather(self._pump, return_exceptions=True)
        for page in list(self.pages):
            await page.ws.close()
        if self._runner is not None:
            await self._runner.cleanup()
        await self.feed.stop()

    # --- HTTP ---------------------------------------------------------------------------------

    @web.middleware
    async def _check_host(self, request, handler):
        # On loopback, only loopback names: a site whose name an attacker re-points at
        # 127.0.0.1 (DNS rebinding) is refused.
        if _loopback(self.host):
            name = urlsplit(f"//{request.host}").hostname or ""
            if name not in LOOPBACK_NAMES:
                raise web.HTTPForbidden(
                    text=f"host {request.host!r} refused: open the page as {self.url}"
                )
        return await handler(request)

    async def _index(self, request):
        return web.FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-cache"})

    def _json(self, obj):
        return web.Response(text=strict_json.dumps(obj), content_type="application/json")

    async def _api_streams(self, request):
        now = self.hub.clock()
        return self._json(
            {
                "header": self.header(),
                "rows": [self.hub.streams[s].summary(now) for s in self.hub.order],
            }
        )

    async def _api_stream(self, request):
        sv = self.hub.streams.get(request.match_info["stream"])
        if sv is None:
            raise web.HTTPNotFound(text=f"no stream {request.match_info['stream']!r}")
        return self._json({"row": sv.summary(self.hub.clock()), "timeline": sv.timeline()})

    def header(self) -> dict:
        return {
            **self.hub.header(),
            "publish": self.publish,
            "control": self.control,
            "connected": self.feed.connected,
            "daemon": self.feed.daemon_ok,
            "live": self.feed.live.is_set(),
            "now": self.hub.clock(),
        }

    # --- WebSocket ------------------------------------------------------------------------------

    async def _ws(self, request):
        origin = request.headers.get("Origin")
        if origin is not None and urlsplit(origin).netloc != request.host:
            # another site open in the same browser must not read the streams
            raise web.HTTPForbidden(
                text=f"WebSocket from origin {origin!r} refused: only "
                f"the view's own page ({request.host}) may connect"
            )
        ws = web.WebSocketResponse(heartbeat=30)
        await ws.prepare(request)
        page = _Page(ws)
        self.pages.add(page)
        try:
            now = self.hub.clock()
            await self._send(
                page,
                {
                    "t": "rows",
                    "all": True,
                    "header": self.header(),
                    "rows": [self.hub.streams[s].summary(now) for s in self.hub.order],
                },
            )
            async for msg in ws:
                if msg.type != WSMsgType.TEXT:
                    continue
                try:
                    req = json.loads(msg.data)
                except ValueError:
                    continue
                if isinstance(req, dict) and req.get("op") == "open":
                    page.stream = req.get("stream") if isinstance(req.get("stream"), str) else None
                    page.cut_next = page.rep_next = 0
                    page.seg_version = -1
                    page.has_human = False
                    await self._send_timeline(page)
        finally:
            self.pages.discard(page)
        return ws

    async def _send(self, page: _Page, obj: dict) -> None:
        if page.ws.closed:
            return
        try:
            await page.ws.send_str(strict_json.dumps(obj))
        except (ConnectionError, RuntimeError):
            return  # the page went away; its handler cleans up
        page.sent += 1
        self.sent += 1

    async def _send_timeline(self, page: _Page) -> None:
        sv = self.hub.streams.get(page.stream) if page.stream else None
        if sv is None:
            return
        if page.cut_version != sv.cut_version:  # a cut was withdrawn: redraw the stream whole
            page.cut_next = page.rep_next = 0
            page.seg_version = -1
            page.has_human = False
            page.cut_version = sv.cut_version
        tl = sv.timeline(page.cut_next, page.rep_next, page.seg_version, not page.has_human)
        tl["full"] = page.cut_next == 0 and page.seg_version == -1
        page.cut_next, page.rep_next = tl["cut_next"], tl["rep_next"]
        page.seg_version = tl["seg_version"]
        page.has_human = page.has_human or "human" in tl
        await self._send(page, {"t": "timeline", "row": sv.summary(self.hub.clock()), **tl})

    async def _broadcast(self) -> None:
        header_every = max(1, int(round(1.0 / self.interval)))
        tick = 0
        while True:
            await asyncio.sleep(self.interval)
            tick += 1
            dirty, gone = self.hub.take_dirty()
            if not self.pages or (not dirty and not gone and tick % header_every):
                continue
            now = self.hub.clock()
            rows = [self.hub.streams[s].summary(now) for s in dirty if s in self.hub.streams]
            msg = {
                "t": "rows",
                "all": False,
                "header": self.header(),
                "rows": rows,
                "removed": gone,
            }
            changed = set(dirty)
            for page in list(self.pages):
                await self._send(page, msg)
                if page.stream in changed:
                    await self._send_timeline(page)


class ViewThread:
    """A :class:`ViewServer` on its own event loop in a background thread (for ``serve
    --http``, the demo and tests); :attr:`url` once :meth:`start` returned."""

    def __init__(self, *args, **kwargs):
        self.server = ViewServer(*args, **kwargs)
        self.url = None
        self._loop = None
        self._thread = None
        self._ready = threading.Event()
        self._error = None

    def start(self, timeout: float = 30.0) -> str:
        self._thread = threading.Thread(target=self._run, name="streamseg-view", daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout):
            raise TimeoutError(f"the view did not start in {timeout} s")
        if self._error is not None:
            raise self._error
        return self.url

    def _run(self) -> None:
        self._loop = asyncio.new_event_loop()
        try:
            self.url = self._loop.run_until_complete(self.server.start())
        except Exception as err:  # e.g. the address is in use: reported by start()
            self._error = err
            self._ready.set()
            self._loop.close()
            return
        self._ready.set()
        self._loop.run_forever()
        self._loop.run_until_complete(self.server.stop())
        self._loop.close()

    def stop(self, timeout: float = 10.0) -> None:
        if self._loop is not None and self._thread.is_alive():
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join(timeout)
