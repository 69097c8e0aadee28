"""The live view in a real headless Chromium (Debian's, through Playwright): daemon, view and
replayer on random loopback ports, assertions on the page against the events the daemon
published (collected by a listener of our own)."""

from __future__ import annotations

import contextlib
import dataclasses
import json
import shutil
import tempfile
import threading
import time

import numpy as np
import pytest
import zmq

from streamseg import protocol as P
from streamseg.client import subscriber
from streamseg.commands.replay import replay
from streamseg.config import DaemonConfig, LOFConfig
from streamseg.daemon import Daemon
from streamseg.io import read
from streamseg.protocol.auth import read_token

pytestmark = pytest.mark.daemon
LOOP = "tcp://127.0.0.1:0"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
# the flags keep a CI browser from phoning home or touching the GPU
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]

sync_api = pytest.importorskip(
    "playwright.sync_api", reason="playwright is not installed (pip install -e '.[test]')"
)
pytest.importorskip("aiohttp", reason="aiohttp is not installed (pip install -e '.[view]')")
if CHROMIUM is None:
    pytest.skip(
        "chromium is not installed: apt-get install -y chromium (.ci/run does)",
        allow_module_level=True,
    )

from streamseg.view.server import ViewThread  # noqa: E402  (needs aiohttp)


@pytest.fixture(scope="module")
def browser():
    profile = tempfile.mkdtemp(prefix="streamseg-chromium-")
    with sync_api.sync_playwright() as pw:
        ctx = pw.chromium.launch_persistent_context(
            profile,
            executable_path=CHROMIUM,
            args=CHROMIUM_ARGS,
            headless=True,
            viewport={"width": 1400, "height": 800},
        )
        ctx.set_default_timeout(120_000)  # a slow CI machine; conditions, never sleeps
        yield ctx
        ctx.close()
    shutil.rmtree(profile, ignore_errors=True)


class Live:
    """A daemon, a view of it and a listener that records every event of the daemon."""

    def __init__(self, algorithms=None, **overrides):
        cfg = dict(ingest=LOOP, publish=LOOP, control=LOOP, heartbeat=0.2)
        cfg.update(overrides)
        self.daemon = Daemon(DaemonConfig(**cfg), algorithms)
        self.ep = self.daemon.bind()
        self.thread = threading.Thread(target=self.daemon.run, daemon=True)
        self.thread.start()
        assert self.daemon.ready.wait(60)
        self.events = []
        self.sub = subscriber(self.ep["publish"])
        self.heard = threading.Event()  # the listener's subscription is live
        self.closed: dict = {}
        self._stop = False
        self._listener = threading.Thread(target=self._listen, daemon=True)
        self._listener.start()
        self.view = ViewThread(self.ep["publish"], self.ep["control"], interval=0.05)
        self.url = self.view.start()
        assert self.heard.wait(30), "no heartbeat from the daemon"

    def _listen(self):
        while not self._stop:  # the socket is this thread's: it closes it
            if not self.sub.poll(100):
                continue
            ev = P.decode(self.sub.recv_multipart())
            self.heard.set()
            if ev.type != "stats":
                self.events.append(ev)
            if ev.type == "closed":
                self.closed.setdefault(ev.stream, threading.Event()).set()
        self.sub.close()

    def wait_closed(self, stream, timeout=180):
        ev = self.closed.setdefault(stream, threading.Event())
        assert ev.wait(timeout), f"stream {stream} was not closed"

    def of(self, stream, kind):
        return [e for e in self.events if e.stream == stream and e.type == kind]

    def stop(self):
        self.view.stop()
        self.daemon.stop()
        self.thread.join(30)
        self._stop = True
        self._listener.join(5)


@pytest.fixture
def live():
    made = []

    def start(**overrides):
        made.append(Live(**overrides))
        return made[-1]

    yield start
    for lv in made:
        lv.stop()


def part(rec, stop):
    return dataclasses.replace(
        rec, positions=np.ascontiguousarray(rec.positions[:stop]), rotations=None
    )


def send_rest(endpoint, rec, stream, start, batch=8):
    """Frames ``start..`` of ``rec`` on an already announced stream, then its end: from a new
    connection, so the end carries the control token as a restarted sender's would (the
    stream belongs to the connection that announced it)."""
    push = zmq.Context.instance().socket(zmq.PUSH)
    push.setsockopt(zmq.LINGER, 30000)
    push.connect(endpoint)
    try:
        for a in range(start, rec.n_frames, batch):
            push.send_multipart(
                P.encode(P.Frames(stream, a, time.time(), rec.positions[a : a + batch]))
            )
        push.send_multipart(P.encode(P.End(stream, read_token())))
    finally:
        push.close()


def wait_view_live(page):
    """The view has received a published event (its subscription is live): the header counts
    forwarded events."""
    page.wait_for_function(
        "() => /\\b[1-9][0-9]* events/.test(document.querySelector('#totals').textContent)"
    )


def frames_of(page, selector, attr):
    return sorted(
        int(v)
        for v in page.eval_on_selector_all(
            selector, f"els => els.map(e => e.getAttribute('{attr}'))"
        )
    )


def wait_frames(page, selector, attr, expected):
    """Wait until the page draws exactly ``expected`` (sorted ints of ``attr``): a count alone
    can match a page that has not yet applied a later withdraw and cut. On a timeout the
    caller's assert shows the difference."""
    with contextlib.suppress(sync_api.TimeoutError):
        page.wait_for_function(
            "([sel, attr, want]) => JSON.stringify([...document.querySelectorAll(sel)]"
            ".map(e => +e.getAttribute(attr)).sort((a, b) => a - b)) === want",
            arg=[
                selector,
                attr,
                json.dumps(sorted(int(v) for v in expected), separators=(",", ":")),
            ],
        )


def wait_segments(page, expected):
    """Wait until the page draws exactly the ``expected`` [start, end, label] segments."""
    with contextlib.suppress(sync_api.TimeoutError):
        page.wait_for_function(
            "want => JSON.stringify([...document.querySelectorAll('#seg-layer rect.seg')]"
            ".map(e => [+e.dataset.start, +e.dataset.end, +e.dataset.label])"
            ".sort((a, b) => a[0] - b[0] || a[1] - b[1] || a[2] - b[2])) === want",
            arg=json.dumps(
                sorted([int(a), int(b), int(c)] for a, b, c in expected), separators=(",", ":")
            ),
        )


def segments_of(page):
    return sorted(
        tuple(s)
        for s in page.eval_on_selector_all(
            "#seg-layer rect.seg",
            "els => els.map(e => [+e.dataset.start, +e.dataset.end, +e.dataset.label])",
        )
    )


def test_replay_shows_cuts_segments_labels_and_close(live, browser, rec, data_dir):
    lv = live()
    page = browser.new_page()
    page.goto(lv.url + "#stream=86_01")
    wait_view_live(page)
    labels = data_dir / "cmu86" / "labels_86_01.csv"
    sender = threading.Thread(
        target=replay,
        args=(rec, lv.ep["ingest"]),
        kwargs=dict(stream="86_01", speed=0, batch=8, labels=labels),
    )
    sender.start()
    # listed, opened from the address, then marked closed on the page
    page.wait_for_selector('.row[data-stream="86_01"]')
    page.wait_for_selector("#open:not([hidden])")
    lv.wait_closed("86_01")
    sender.join()
    page.wait_for_selector('.row[data-stream="86_01"][data-closed="end"]')
    page.wait_for_function("() => document.querySelector('#status').textContent === 'closed (end)'")

    # the page lists the cuts not withdrawn (every provisional cut ends confirmed or
    # withdrawn by a relabel: docs/protocol.md, Settled cuts)
    kept = list(lv.of("86_01", "cut"))
    for w in lv.of("86_01", "withdraw"):
        kept.remove(next(c for c in kept if c.frame == w.frame))
    cuts = sorted(c.frame for c in kept)
    final = [e for e in lv.of("86_01", "segments") if e.final]
    assert cuts and len(final) == 1
    expected = sorted(tuple(s) for s in final[0].segments)
    assert final[0].start == 0 and final[0].end == rec.n_frames  # one relabel covers it all
    wait_frames(page, "#cut-layer line.cut", "data-frame", cuts)
    assert frames_of(page, "#cut-layer line.cut", "data-frame") == cuts
    emitted = {e.frame: e.emitted_at for e in kept}
    assert frames_of(page, "#cut-layer line.cut", "data-emitted") == sorted(emitted.values())
    wait_segments(page, expected)
    assert segments_of(page) == expected
    # the colour key names every relabelled id; the current action is the last segment's
    keys = page.eval_on_selector_all("#key [data-label]", "els => els.map(e => +e.dataset.label)")
    assert sorted(keys) == sorted({s[2] for s in expected})
    assert page.get_attribute("#action b", "data-label") == str(expected[-1][2])

    # human labels overlaid, agreement shown (the file's rows, 0-based, ends exclusive)
    from streamseg.evaluation.labels import read_labels

    human = read_labels(labels, "86_01")
    page.wait_for_function(
        f"() => document.querySelectorAll('#human-layer rect').length === {len(human)}"
    )
    shown = page.eval_on_selector_all(
        "#human-layer rect",
        "els => els.map(e => [+e.dataset.start, +e.dataset.end, e.dataset.name])",
    )
    assert sorted(map(tuple, shown)) == sorted((s.start, s.end, s.label) for s in human)
    page.wait_for_selector("#agreement:has-text('frame accuracy')")

    # a page opened after the stream ended shows the whole history
    late = browser.new_page()
    late.goto(lv.url + "#stream=86_01")
    late.wait_for_selector('.row[data-stream="86_01"][data-closed="end"]')
    wait_frames(late, "#cut-layer line.cut", "data-frame", cuts)
    assert frames_of(late, "#cut-layer line.cut", "data-frame") == cuts
    wait_segments(late, expected)
    assert segments_of(late) == expected
    page.close()
    late.close()


def test_view_started_late_catches_up_through_state(browser, rec):
    """A view that connects while a stream is running gets its past from the ``state``
    snapshot and the rest from events: the page ends with every cut the daemon published."""
    cfg = DaemonConfig(ingest=LOOP, publish=LOOP, control=LOOP, heartbeat=0.2, relabel_interval=0)
    daemon = Daemon(cfg)
    ep = daemon.bind()
    t = threading.Thread(target=daemon.run, daemon=True)
    t.start()
    assert daemon.ready.wait(60)
    half = rec.n_frames // 2
    replay(part(rec, half), ep["ingest"], stream="late", speed=0, batch=8, end=False)
    view = ViewThread(ep["publish"], ep["control"], interval=0.05)
    try:
        url = view.start()
        page = browser.new_page()
        page.goto(url + "#stream=late")
        wait_view_live(page)
        send_rest(ep["ingest"], rec, "late", half)
        page.wait_for_selector('.row[data-stream="late"][data-closed="end"]', timeout=120_000)
        from streamseg.client import request

        state = request(ep["control"], "state", stream="late")
        assert state["closed"] == "end"
        want = sorted({c["frame"] for c in state["cuts"]})  # no relabel: the daemon kept all
        page.wait_for_function(
            f"() => document.querySelectorAll('#cut-layer line.cut').length === {len(want)}"
        )
        shown = frames_of(page, "#cut-layer line.cut", "data-frame")
        assert shown == want
        assert shown and min(shown) < half  # cuts from before the view started are there
        page.close()
    finally:
        view.stop()
        daemon.stop()
        t.join(30)


def test_a_withdrawn_pending_cut_leaves_the_page(live, browser, rec):
    """The two-stage decision: the page draws 86_01's first pending cut that is later
    withdrawn (the replay pauses right after it was emitted), then, once the rest arrives and
    it is withdrawn, redraws without it; the page ends with the final cuts."""
    from streamseg.daemon.algorithms import Algorithms
    from streamseg.online import StreamingLOFSegmenter, WithdrawEvent, final_cuts
    from tests.motion import lof_input

    two = LOFConfig(delay_s=1.5, early_delay_s=1.2)  # as tests/test_lof_two_stage.py
    det = StreamingLOFSegmenter(two, rec.fps)
    events = det.learn_many(lof_input(rec.positions, rec.skeleton, rec.fps))
    events += det.finish()
    withdrawn = {e.frame for e in events if isinstance(e, WithdrawEvent)}
    pending = [e for e in events if getattr(e, "pending", False) and e.frame in withdrawn]
    assert pending
    f = pending[0].frame
    withdraw = [e for e in events if isinstance(e, WithdrawEvent) and e.frame == f]
    assert pending[0].emitted_at < withdraw[0].emitted_at
    final = sorted(c.frame for c in final_cuts(events))
    assert f not in final
    lv = live(algorithms=Algorithms(two), relabel_interval=0)
    page = browser.new_page()
    page.goto(lv.url + "#stream=w")
    wait_view_live(page)
    stop = pending[0].emitted_at + 1  # the frame that emits the pending cut, not the withdraw
    replay(part(rec, stop), lv.ep["ingest"], stream="w", speed=0, batch=8, end=False)
    page.wait_for_selector(f'#cut-layer line.cut[data-frame="{f}"]', state="attached")
    send_rest(lv.ep["ingest"], rec, "w", stop)
    lv.wait_closed("w")
    page.wait_for_selector('.row[data-stream="w"][data-closed="end"]')
    page.wait_for_function(
        f"() => !document.querySelector('#cut-layer line.cut[data-frame=\"{f}\"]')"
    )
    wait_frames(page, "#cut-layer line.cut", "data-frame", final)
    assert frames_of(page, "#cut-layer line.cut", "data-frame") == final
    assert [e.frame for e in lv.of("w", "withdraw")] == [
        e.frame for e in events if isinstance(e, WithdrawEvent)
    ]
    page.close()


def test_hundred_streams_list_is_virtual_and_filterable(live, browser, rec):
    lv = live(relabel_interval=0, max_streams=200)
    page = browser.new_page()
    page.goto(lv.url)
    wait_view_live(page)
    short = part(rec, 1200)
    push = zmq.Context.instance().socket(zmq.PUSH)
    push.setsockopt(zmq.LINGER, 30000)
    push.connect(lv.ep["ingest"])
    names = [f"s{i:03d}" for i in range(100)]
    try:
        for name in names:
            replay(short, lv.ep["ingest"], stream=name, speed=0, batch=48, sock=push)
    finally:
        push.close()
    for name in names:
        lv.wait_closed(name)
    page.wait_for_function(
        "() => document.querySelector('#count').textContent.startsWith('100 streams (0 open)')"
    )
    rendered = page.eval_on_selector_all(".row", "els => els.length")
    assert 0 < rendered < 40  # only the visible rows are in the DOM
    page.fill("#filter", "s077")
    page.wait_for_selector('.row[data-stream="s077"]')
    assert page.eval_on_selector_all(".row", "els => els.map(e => e.dataset.stream)") == ["s077"]
    page.fill("#filter", "")
    page.eval_on_selector("#list", "el => { el.scrollTop = el.scrollHeight; }")
    page.wait_for_selector('.row[data-stream="s099"][data-closed="end"]')
    page.click('.row[data-stream="s099"]')
    n_cuts = len(lv.of("s099", "cut"))
    assert n_cuts > 0
    page.wait_for_function(
        f"() => document.querySelector('#title').textContent === 's099' && "
        f"document.querySelectorAll('#cut-layer line.cut').length === "
        f"{n_cuts}"
    )
    assert frames_of(page, "#cut-layer line.cut", "data-frame") == sorted(
        e.frame for e in lv.of("s099", "cut")
    )
    page.close()


def test_repetitions_gaps_and_errors_reach_the_page(live, browser, data_dir):
    """Repetitions on: the live count of the set and each repetition on the timeline; a lost
    packet shows as a gap, a repeated one in the errors by kind."""
    lv = live(repetitions=True, relabel_interval=0)
    rec = read(
        data_dir / "cmu_exercise" / "14_14.amc.gz", skeleton=data_dir / "cmu86" / "86.asf"
    ).slice(0, 1800)  # jumping jacks
    page = browser.new_page()
    page.goto(lv.url + "#stream=reps")
    wait_view_live(page)
    push = zmq.Context.instance().socket(zmq.PUSH)
    push.setsockopt(zmq.LINGER, 30000)
    push.connect(lv.ep["ingest"])
    from streamseg.commands.replay import announce_of

    push.send_multipart(P.encode(announce_of(rec, "reps")))
    for a in range(0, rec.n_frames, 30):
        if a != 900:  # one packet lost: frames 900..929
            push.send_multipart(
                P.encode(P.Frames("reps", a, time.time(), rec.positions[a : a + 30]))
            )
        if a == 600:  # and one sent twice: 30 duplicate frames
            push.send_multipart(
                P.encode(P.Frames("reps", a, time.time(), rec.positions[a : a + 30]))
            )
    push.send_multipart(P.encode(P.End("reps")))
    push.close()
    lv.wait_closed("reps")
    page.wait_for_selector('.row[data-stream="reps"][data-closed="end"]')
    reps = [(e.start, e.end, e.count) for e in lv.of("reps", "rep")]
    assert len(reps) >= 3
    page.wait_for_function(
        f"() => document.querySelectorAll('#rep-layer rect.rep').length === {len(reps)}"
    )
    shown = page.eval_on_selector_all(
        "#rep-layer rect.rep",
        "els => els.map(e => [+e.dataset.start, +e.dataset.end, +e.dataset.count])",
    )
    assert [tuple(r) for r in shown] == reps
    assert page.text_content("#rep-count") == str(reps[-1][2])
    assert f"{reps[-1][2]} reps" in page.text_content('.row[data-stream="reps"]')
    assert [(e.expected, e.got) for e in lv.of("reps", "gap")] == [(900, 930)]
    assert page.text_content('#health dd[data-k="gaps"]') == "1"
    errors = {e.reason: e.count for e in lv.of("reps", "error")}
    assert errors.get("duplicate") == 30
    page.wait_for_function(
        "() => document.querySelector('#health dd[data-k=\"errors\"]')"
        ".textContent.includes('duplicate×30')"
    )
    assert "errors duplicate×30" in page.text_content('.row[data-stream="reps"]')
    page.close()


def test_the_only_stream_opens_by_itself(live, browser, rec):
    """No stream asked for in the address: the page opens the only one, not "Pick a stream"."""
    lv = live()
    page = browser.new_page()
    page.goto(lv.url)
    wait_view_live(page)
    replay(part(rec, 600), lv.ep["ingest"], stream="solo", speed=0, batch=8)
    page.wait_for_function("() => document.querySelector('#title').textContent === 'solo'")
    assert page.is_hidden("#empty") and page.is_visible("#open")
    assert page.evaluate("location.hash") == "#stream=solo"
    page.close()


def test_the_page_says_when_no_daemon_is_there(browser):
    """A view of an endpoint where no daemon runs says so (not "connected"); once a daemon
    binds there the page says connected, and when it stops, says so again."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    publish = f"tcp://127.0.0.1:{port}"
    view = ViewThread(publish, None, interval=0.05)
    daemon = thread = None
    try:
        url = view.start()
        page = browser.new_page()
        page.goto(url)
        page.wait_for_function("() => document.querySelector('#conn').dataset.state === 'nodaemon'")
        assert page.text_content("#conn") == f"no daemon at {publish}: waiting for it"
        daemon = Daemon(DaemonConfig(ingest=LOOP, publish=publish, control=LOOP, heartbeat=0.2))
        daemon.bind()
        thread = threading.Thread(target=daemon.run, daemon=True)
        thread.start()
        page.wait_for_function("() => document.querySelector('#conn').textContent === 'connected'")
        daemon.stop()
        thread.join(30)
        daemon = None
        page.wait_for_function("() => document.querySelector('#conn').dataset.state === 'nodaemon'")
        page.close()
    finally:
        view.stop()
        if daemon is not None:
            daemon.stop()
            thread.join(30)
