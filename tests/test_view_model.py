"""The view's bookkeeping (no browser): announce ``labels``, late-join merging, agreement."""

from __future__ import annotations

import threading

import msgpack
import pytest

from streamseg import protocol as P
from streamseg.cli import main
from streamseg.client import request
from streamseg.commands.replay import announce_of, replay
from streamseg.config import DaemonConfig
from streamseg.daemon import Daemon
from streamseg.evaluation.labels import read_labels
from streamseg.view.agreement import HumanLabels
from streamseg.view.model import Hub
from tests.cli_words import FREE_PORTS, STREAMSEG

LOOP = "tcp://127.0.0.1:0"


def test_announce_labels_is_optional_and_checked(rec, data_dir):
    plain = P.encode(announce_of(rec, "a"))
    body = msgpack.unpackb(plain[1], raw=False)
    assert "labels" not in body and "labels_sequence" not in body  # old readers see v1 as is
    assert P.decode(plain).labels is None
    csv = data_dir / "cmu86" / "labels_86_01.csv"
    msg = P.decode(P.encode(announce_of(rec, "a", csv, "86_01")))
    assert msg.labels == str(csv.resolve()) and msg.labels_sequence == "86_01"
    body["labels"] = 7
    with pytest.raises(P.WireError, match="announce.labels=7 is invalid") as err:
        P.decode([plain[0], msgpack.packb(body)])
    assert err.value.kind == "field"


def test_daemon_passes_the_announced_labels_on_in_state(rec, data_dir):
    daemon = Daemon(
        DaemonConfig(ingest=LOOP, publish=LOOP, control=LOOP, heartbeat=0, relabel_interval=0)
    )
    ep = daemon.bind()
    t = threading.Thread(target=daemon.run, daemon=True)
    t.start()
    try:
        assert daemon.ready.wait(60)
        csv = data_dir / "cmu86" / "labels_86_01.csv"
        short = rec.__class__(rec.fps, rec.skeleton, rec.positions[:300])
        replay(
            short, ep["ingest"], stream="x", speed=0, batch=50, labels=csv, labels_sequence="86_01"
        )
        replay(short, ep["ingest"], stream="y", speed=0, batch=50)
        for stream, want in (("x", {"path": str(csv.resolve()), "sequence": "86_01"}), ("y", None)):
            state = request(ep["control"], "state", stream=stream)
            while not state.get("closed"):  # end is handled in order after the frames
                state = request(ep["control"], "state", stream=stream)
            assert state.get("labels") == want
    finally:
        daemon.stop()
        t.join(30)


def _events():
    return [
        P.Cut("s", 100, 0.0, 2.0, 130),
        P.Cut("s", 300, 0.0, 2.5, 330),
        P.Segments("s", 1, 0, 400, ((0, 100, 0), (100, 300, 1), (300, 400, 0))),
        P.Cut("s", 500, 0.0, 3.0, 540),
        P.Segments("s", 2, 200, 600, ((200, 300, 1), (300, 500, 2), (500, 600, 1))),
        P.Rep("s", 500, 560, 1, 0.0, 560),
        P.Rep("s", 560, 600, 2, 0.0, 600),
    ]


def _snapshot():
    """What the daemon's ``state`` answers after the events of :func:`_events`."""
    return {
        "stream": "s",
        "fps": 100.0,
        "frame": 620,
        "revision": 2,
        "segments": P.to_json(_events()[4]),
        "cuts": [],
    }


def test_snapshot_and_events_merge_in_either_order():
    fixed = {}
    for name, steps in (
        ("events first", ["events", "state"]),
        ("state first", ["state", "events"]),
        ("state twice", ["state", "events", "state"]),
    ):
        hub = Hub(clock=lambda: 1000.0)
        for step in steps:
            if step == "state":
                hub.apply_state(_snapshot())
            else:
                for ev in _events():
                    hub.apply(ev)
        sv = hub.streams["s"]
        fixed[name] = (sv.segments, [c["frame"] for c in sv.cuts], sv.reps, sv.revision)
    # events first: revision 1 labelled [0, 200) before revision 2 covered [200, 600)
    assert fixed["events first"][0] == [
        [0, 100, 0],
        [100, 200, 1],
        [200, 300, 1],
        [300, 500, 2],
        [500, 600, 1],
    ]
    assert fixed["events first"][1] == [100, 300, 500]
    # state first: revision 1 is older than the snapshot and ignored; cuts are not repeated
    assert fixed["state first"][0] == [[200, 300, 1], [300, 500, 2], [500, 600, 1]]
    assert fixed["state twice"] == fixed["state first"]
    sv = hub.streams["s"]
    assert sv.current_action() == [1, 500] and sv.rep_count() == 2 and sv.frame == 620


def test_a_stream_announced_again_starts_over_after_closed():
    hub = Hub(clock=lambda: 0.0)
    for ev in _events() + [P.Closed("s", "end", 620), P.Cut("s", 50, 0.0, 1.0, 80)]:
        hub.apply(ev)
    sv = hub.streams["s"]
    assert sv.closed is None and [c["frame"] for c in sv.cuts] == [50] and not sv.segments
    # a snapshot saying "closed" (final relabel pending) does not throw away what follows
    hub.apply_state({**_snapshot(), "closed": "end"})
    hub.apply(P.Segments("s", 3, 0, 620, ((0, 620, 4),), final=True))
    assert hub.streams["s"].segments == [[0, 620, 4]] and hub.streams["s"].closed == "end"


def test_timeline_cursors_send_only_what_is_new():
    hub = Hub(clock=lambda: 0.0)
    for ev in _events()[:3]:
        hub.apply(ev)
    sv = hub.streams["s"]
    first = sv.timeline()
    assert [c["frame"] for c in first["cuts"]] == [100, 300] and "segments" in first
    hub.apply(_events()[3])
    nxt = sv.timeline(first["cut_next"], first["rep_next"], first["seg_version"])
    assert [c["frame"] for c in nxt["cuts"]] == [500] and "segments" not in nxt


def test_agreement_against_the_human_labels(data_dir):
    csv = data_dir / "cmu86" / "labels_86_01.csv"
    human = HumanLabels.read(csv, "86_01")
    rows = read_labels(csv, "86_01")
    names = sorted({r.label for r in rows})
    perfect = [[r.start, r.end, names.index(r.label)] for r in rows]
    cuts = [{"frame": r.end} for r in rows[:-1]]
    ag = human.agreement(perfect, cuts, 120.0)
    assert ag["frame_accuracy"] == 1.0 and ag["cut_recall"] == 1.0
    assert ag["boundaries"] == len(rows) - 1 and ag["frames"] == rows[-1].end
    assert ag["match"] == {str(i): n for i, n in enumerate(names)}
    # halfway: only the boundaries whose window the relabel has passed are counted
    half = [s for s in perfect if s[1] <= 2000]
    ag = human.agreement(half, [], 120.0)
    assert ag["cut_recall"] == 0.0 and 0 < ag["boundaries"] < len(rows) - 1
    one = human.agreement([[0, rows[-1].end, 0]], [], 120.0)
    assert one["frame_accuracy"] < 0.5  # one label for everything agrees little


def test_view_command_explains_a_bad_address(capsys):
    pytest.importorskip("aiohttp")
    assert main(["view", "--from", "tcp://127.0.0.1:1", "--http", "here"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "expected HOST:PORT" in err


def _line_with(proc, text: str, limit: int = 50) -> str:
    for _ in range(limit):
        line = proc.stdout.readline()
        if text in line or not line:
            return line
    return ""


def test_serve_http_and_view_commands_serve_the_page():
    """``serve --http`` and ``view`` as a user runs them: the printed address answers with
    the page and the JSON of the streams; SIGTERM/SIGINT stop both cleanly."""
    pytest.importorskip("aiohttp")
    import json
    import signal
    import subprocess
    import urllib.request

    serve = subprocess.Popen(
        [
            *STREAMSEG,
            "serve",
            *FREE_PORTS,
            "--http",
            "127.0.0.1:0",
            "--log-level",
            "WARNING",
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    view = None
    try:
        endpoints = _line_with(serve, "streamseg serve: ingest=")
        ep = dict(kv.split("=", 1) for kv in endpoints.split(": ", 1)[1].split())
        url = _line_with(serve, "live view ").split("live view ")[1].strip()
        assert url.startswith("http://127.0.0.1:")
        page = urllib.request.urlopen(url).read().decode()
        assert '<svg id="timeline"' in page and "static/view.js" in page
        import re

        links = re.findall(r'(?:src|href)="([^"]*)"', page)
        assert links and all(u.startswith("static/") for u in links)  # served here, no CDN
        js = urllib.request.urlopen(url + "static/view.js").read().decode()
        rest = js.replace('"http://www.w3.org/2000/svg"', "").replace('"https:"', "")
        assert "new WebSocket" in js and "http" not in rest and "import " not in rest
        api = json.load(urllib.request.urlopen(url + "api/streams"))
        assert api["rows"] == [] and api["header"]["control"] == ep["control"]
        view = subprocess.Popen(
            [
                *STREAMSEG,
                "view",
                "--from",
                ep["publish"],
                "--control",
                ep["control"],
                "--http",
                "127.0.0.1:0",
            ],
            stdout=subprocess.PIPE,
            text=True,
        )
        line = _line_with(view, "streamseg view: http://")
        other = line.split("streamseg view: ", 1)[1].split()[0]
        assert json.load(urllib.request.urlopen(other + "api/streams"))["rows"] == []
        view.send_signal(signal.SIGINT)
        assert view.wait(30) == 0
        serve.send_signal(signal.SIGTERM)
        assert serve.wait(60) == 0
    finally:
        for p in (serve, view):
            if p is not None and p.poll() is None:
                p.kill()
                p.wait()


def test_the_oldest_closed_streams_are_forgotten_beyond_the_limit():
    hub = Hub(clock=lambda: 0.0)
    hub.max_closed = 3
    hub.apply(P.Cut("open", 5, 0.0, 1.0, 9))
    for i in range(5):
        hub.apply(P.Cut(f"c{i}", 5, 0.0, 1.0, 9))
        hub.apply(P.Closed(f"c{i}", "end", 10))
    changed, gone = hub.take_dirty()
    assert gone == ["c0", "c1"] and "c0" not in changed
    assert hub.order == ["c2", "c3", "c4", "open"] and set(hub.streams) == set(hub.order)
    assert hub.take_dirty() == ([], [])


def test_websocket_refuses_other_origins_and_hosts():
    """A page of another site in the same browser cannot read the streams (cross-site
    WebSocket, or DNS rebinding: another name for 127.0.0.1); the view's own page and
    non-browser clients (no Origin) can."""
    aiohttp = pytest.importorskip("aiohttp")
    import asyncio

    from streamseg.view.server import ViewThread

    view = ViewThread("tcp://127.0.0.1:1", None)  # no daemon needed to answer the socket
    url = view.start()

    async def attempt(origin):
        headers = {"Origin": origin} if origin else {}
        async with aiohttp.ClientSession() as session:
            try:
                async with session.ws_connect(url + "ws", headers=headers) as ws:
                    msg = await ws.receive_json(timeout=10)
                    return msg["t"]
            except aiohttp.WSServerHandshakeError as err:
                return err.status

    try:
        own = url.rstrip("/")
        assert asyncio.run(attempt(own)) == "rows"
        assert asyncio.run(attempt(None)) == "rows"
        assert asyncio.run(attempt("http://evil.example")) == 403
        import urllib.error
        import urllib.request

        port = url.rsplit(":", 1)[1].strip("/")
        rebound = urllib.request.Request(
            url + "api/streams", headers={"Host": f"evil.example:{port}"}
        )
        with pytest.raises(urllib.error.HTTPError) as err:
            urllib.request.urlopen(rebound)
        assert err.value.code == 403
        local = urllib.request.Request(url + "api/streams", headers={"Host": f"localhost:{port}"})
        assert urllib.request.urlopen(local).status == 200
    finally:
        view.stop()


def test_a_stream_lost_in_a_daemon_crash_is_marked_lost(rec):
    """kill -9 the daemon mid-stream and start another on the same endpoints: the view
    notices (the new daemon does not know the stream) and marks it closed, ``lost``."""
    pytest.importorskip("aiohttp")
    import json
    import signal
    import subprocess
    import urllib.request

    from streamseg.view.server import ViewThread

    def serve(ingest="tcp://127.0.0.1:0", publish="tcp://127.0.0.1:0", control="tcp://127.0.0.1:0"):
        p = subprocess.Popen(
            [
                *STREAMSEG,
                "serve",
                "--ingest",
                ingest,
                "--publish",
                publish,
                "--control",
                control,
                "--log-level",
                "WARNING",
                "--relabel-interval",
                "0",
            ],
            stdout=subprocess.PIPE,
            text=True,
        )
        line = _line_with(p, "streamseg serve: ingest=")
        return p, dict(kv.split("=", 1) for kv in line.split(": ", 1)[1].split())

    def rows(url):
        return {
            r["stream"]: r for r in json.load(urllib.request.urlopen(url + "api/streams"))["rows"]
        }

    def until(cond, what, limit=60.0):
        """Follow the view's WebSocket (as a page does) until ``cond(rows)`` holds."""
        import asyncio

        import aiohttp

        async def follow():
            seen = {}
            async with aiohttp.ClientSession() as session:
                async with session.ws_connect(url + "ws") as ws:
                    async for msg in ws:
                        m = json.loads(msg.data)
                        if m["t"] != "rows":
                            continue
                        if m["all"]:
                            seen.clear()
                        seen.update((r["stream"], r) for r in m["rows"])
                        if cond(seen):
                            return

        try:
            asyncio.run(asyncio.wait_for(follow(), limit))
        except asyncio.TimeoutError:
            raise AssertionError(f"not seen in {limit} s: {what}") from None

    first, ep = serve()
    second = view = None
    try:
        view = ViewThread(ep["publish"], ep["control"], poll=0.2)
        url = view.start()
        view.server.feed.timeout = 1.0
        replay(
            rec.__class__(rec.fps, rec.skeleton, rec.positions[:600]),
            ep["ingest"],
            stream="gone",
            speed=0,
            batch=50,
            end=False,
        )
        until(lambda r: r.get("gone", {}).get("frame") == 600, "the stream's frames")
        assert rows(url)["gone"]["closed"] is None
        first.send_signal(signal.SIGKILL)
        first.wait(30)
        second, _ = serve(ep["ingest"], ep["publish"], ep["control"])
        until(lambda r: r.get("gone", {}).get("closed") == "lost", "the stream marked lost")
        assert rows(url)["gone"]["closed"] == "lost"
    finally:
        if view is not None:
            view.stop()
        for p in (first, second):
            if p is not None and p.poll() is None:
                p.send_signal(signal.SIGTERM)
                p.wait(60)
