"""CURVE on all three sockets, key files, the loopback rule, and the per-client quota."""

from __future__ import annotations

import functools

import pytest
import zmq
from zmq.utils.monitor import recv_monitor_message

from streamseg import protocol as P
from streamseg.cli import main
from streamseg.client import listen, request, subscriber
from streamseg.commands.replay import announce_of, replay
from streamseg.config import DaemonConfig
from streamseg.daemon import Daemon
from streamseg.daemon.security import ClientKeys, generate, is_loopback
from streamseg.exceptions import ParameterError
from streamseg.online.lof import StreamingLOFSegmenter
from tests.cli_words import listen_to
from tests.motion import lof_input
from tests.waiting import wait_until

pytestmark = pytest.mark.daemon
LOOP = "tcp://127.0.0.1:0"


@pytest.fixture
def keys(tmp_path, capsys):
    assert main(["keys", str(tmp_path / "keys"), "--clients", "2"]) == 0
    assert "authorized" in capsys.readouterr().out
    return tmp_path / "keys"


@pytest.fixture
def secure_daemon(keys, start_daemon):
    """The shared daemon starter with CURVE on, keys from ``keys``."""
    return functools.partial(start_daemon, heartbeat=0, curve_dir=str(keys))


def handshake(sock, endpoint) -> int:
    """Connect ``sock`` and return the first handshake outcome its monitor reports."""
    mon = sock.get_monitor_socket(
        zmq.EVENT_HANDSHAKE_SUCCEEDED
        | zmq.EVENT_HANDSHAKE_FAILED_AUTH
        | zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL
        | zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL
    )
    sock.connect(endpoint)
    try:
        assert mon.poll(20000), "no handshake event"
        return recv_monitor_message(mon)["event"]
    finally:
        sock.disable_monitor()
        mon.close(linger=0)


def offline_cuts(rec):
    seg = StreamingLOFSegmenter(fps=rec.fps)
    ang = lof_input(rec.positions, rec.skeleton, rec.fps)
    return [c.frame for c in seg.learn_many(ang) + seg.finish()]


def test_curve_end_to_end_and_a_stranger_is_refused(secure_daemon, keys, rec, tmp_path):
    d, ep = secure_daemon()
    me = ClientKeys.load(keys)
    ctx = zmq.Context.instance()
    # an authorised client: replay, listen and control all work over CURVE
    s = subscriber(ep["publish"], stream="safe", curve=me)
    assert handshake(s, ep["publish"]) == zmq.EVENT_HANDSHAKE_SUCCEEDED
    assert request(ep["control"], "ping", curve=me)["ok"]
    replay(rec, ep["ingest"], stream="safe", speed=0, batch=50, curve=me, wait=20)
    events = list(listen(s, stream="safe", until_end=True, timeout=30))
    assert [e.frame for e in events if e.type == "cut"] == offline_cuts(rec)
    # a stranger: keys of its own, not in authorized/: every socket refuses the handshake
    generate(tmp_path / "stranger")
    own = ClientKeys.load(tmp_path / "stranger")
    stranger = ClientKeys(own.public, own.secret, me.server)  # it knows the server's key
    for name, kind in (("ingest", zmq.PUSH), ("publish", zmq.SUB), ("control", zmq.REQ)):
        sock = ctx.socket(kind)
        stranger.apply(sock)
        assert handshake(sock, ep[name]) == zmq.EVENT_HANDSHAKE_FAILED_AUTH, name
        sock.close(linger=0)
    # and a plain (no CURVE) client does not get through either
    plain = ctx.socket(zmq.PUSH)
    assert handshake(plain, ep["ingest"]) != zmq.EVENT_HANDSHAKE_SUCCEEDED
    plain.close(linger=0)
    # a control client is told at once why, not after its timeout
    with pytest.raises(ConnectionRefusedError, match="refused this client's CURVE key"):
        request(ep["control"], "shutdown", curve=stranger, timeout=60)
    with pytest.raises(ConnectionRefusedError, match="it has CURVE on: give --curve-dir"):
        request(ep["control"], "shutdown", timeout=60)
    assert not d._stop.is_set()
    assert request(ep["control"], "stats", curve=me)["totals"]["streams_opened"] == 1
    # the authorised key may shut the daemon down
    assert request(ep["control"], "shutdown", curve=me)["ok"]
    assert d._stop.wait(10)


def test_cli_replay_and_listen_take_keys(secure_daemon, keys, data_dir, capsys, tmp_path):
    d, ep = secure_daemon(state_dir=str(tmp_path / "state"))
    files = [
        str(data_dir / "cmu86" / "86_01.amc.gz"),
        "--skeleton",
        str(data_dir / "cmu86" / "86.asf"),
    ]
    assert (
        main(
            [
                "replay",
                *files,
                "--to",
                ep["ingest"],
                "--speed",
                "0",
                "--batch",
                "50",
                "--stream",
                "k",
                "--curve-dir",
                str(keys),
            ]
        )
        == 0
    )
    assert (
        main(
            [
                *listen_to(ep),
                "--stream",
                "k",
                "--since",
                "0",
                "--curve-dir",
                str(keys),
                "--until-end",
                "--timeout",
                "30",
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert "sent 4579 frames" in printed and "closed   (end)" in printed
    assert "] cut " in printed


def test_non_loopback_bind_needs_curve_or_insecure(keys):
    cfg = DaemonConfig(ingest="tcp://0.0.0.0:0", publish=LOOP, control=LOOP)
    with pytest.raises(ParameterError, match="not a loopback address and CURVE is off"):
        Daemon(cfg).bind()
    for ok in (dict(insecure=True), dict(curve_dir=str(keys))):
        d = Daemon(DaemonConfig(ingest="tcp://0.0.0.0:0", publish=LOOP, control=LOOP, **ok))
        assert d.bind()["ingest"].startswith("tcp://0.0.0.0:")
        d._shutdown()
    assert is_loopback("tcp://127.0.0.1:5560") and is_loopback("tcp://[::1]:5560")
    assert is_loopback("tcp://localhost:1") and is_loopback("ipc:///tmp/x")
    assert not is_loopback("tcp://*:5560") and not is_loopback("tcp://0.0.0.0:5560")
    assert not is_loopback("tcp://10.1.2.3:5560")


def test_cli_refuses_a_public_bind_in_one_line(capsys):
    assert (
        main(
            [
                "serve",
                "--ingest",
                "tcp://0.0.0.0:0",
                "--publish",
                LOOP,
                "--control",
                LOOP,
                "--state-dir",
                "none",
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--insecure" in err[0]


def test_quota_keeps_a_slot_for_another_client(secure_daemon, keys, rec):
    """One key announces 10 streams; with a quota of 3 and 5 slots the second key's stream
    is still accepted and cut."""
    d, ep = secure_daemon(max_streams=5, max_streams_per_client=3)
    flood, other = ClientKeys.load(keys), ClientKeys.load(keys, "client2")
    ctx = zmq.Context.instance()
    s = subscriber(ep["publish"], curve=other)
    assert handshake(s, ep["publish"]) == zmq.EVENT_HANDSHAKE_SUCCEEDED
    a = ctx.socket(zmq.PUSH)
    flood.apply(a)
    a.connect(ep["ingest"])
    for k in range(10):
        a.send_multipart(P.encode(announce_of(rec, f"flood{k}")))
    a.close(linger=5000)
    seen = []
    for e in listen(s, timeout=20):
        seen.append(e)
        if sum(x.type == "error" and x.reason == "quota" for x in seen) >= 1:
            break
    replay(rec, ep["ingest"], stream="legit", speed=0, batch=50, curve=other, wait=20)
    events = [e for e in listen(s, stream="legit", until_end=True, timeout=30)]
    legit = [e for e in events if e.stream == "legit"]
    assert [e.frame for e in legit if e.type == "cut"] == offline_cuts(rec)
    streams = {x["stream"] for x in request(ep["control"], "streams", curve=other)["streams"]}
    assert streams == {"flood0", "flood1", "flood2"}
    errs = request(ep["control"], "stats", curve=other)["totals"]["errors_by_reason"]
    assert errs["quota"] == 7


def test_the_view_follows_a_curve_daemon_with_keys(secure_daemon, keys, rec):
    pytest.importorskip("aiohttp")
    import json
    import urllib.request

    from streamseg.view.server import ViewThread

    d, ep = secure_daemon()
    me = ClientKeys.load(keys)
    view = ViewThread(ep["publish"], ep["control"], poll=0.2, curve=me)
    url = view.start()
    try:
        replay(
            rec.__class__(rec.fps, rec.skeleton, rec.positions[:600]),
            ep["ingest"],
            stream="seen",
            speed=0,
            batch=50,
            curve=me,
            wait=20,
            end=False,
        )

        def seen():  # the page's stream list, as a browser polls it
            rows = json.load(urllib.request.urlopen(url + "api/streams"))["rows"]
            return any(r["stream"] == "seen" and r.get("frame") == 600 for r in rows)

        wait_until(seen, "the view listed stream seen at frame 600", timeout=30)
    finally:
        view.stop()


def test_listen_says_why_its_key_is_refused(secure_daemon, keys, start_daemon, tmp_path, capsys):
    d, ep = secure_daemon()
    generate(tmp_path / "stranger")
    stranger = tmp_path / "stranger"
    (stranger / "server.key").write_bytes((keys / "server.key").read_bytes())
    args = [
        *listen_to(ep),
        "--stream",
        "x",
        "--count",
        "1",
    ]
    for extra, why in (
        ([], "it has CURVE on"),
        (["--curve-dir", str(stranger)], "refused this client's CURVE key"),
    ):
        assert main(args + extra) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and why in err[0], err
    # without --control only the SUB socket is there to notice: it says so too, at once
    # (before, it waited for events: here until the timeout, with the timeout's message)
    sub_only = ["listen", "--from", ep["publish"], "--count", "1", "--timeout", "30"]
    for extra, why in (
        ([], "it has CURVE on"),
        (["--curve-dir", str(stranger)], "refused this client's CURVE key"),
    ):
        assert main(sub_only + extra) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and why in err[0], err
    # CURVE keys given to a daemon without CURVE
    _, plain = start_daemon(heartbeat=0)
    assert (
        main(
            [
                *listen_to(plain),
                "--count",
                "1",
                "--curve-dir",
                str(keys),
            ]
        )
        == 1
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "refused the security handshake" in err[0], err
    assert not d._stop.is_set()


class _RefusedFirst(zmq.Socket):
    """A REQ socket whose ``connect`` returns once the daemon has refused its handshake (the
    connection and its queue are gone: it takes no message): the order a loaded machine may
    give :func:`request`, between its connect and its send, made certain."""

    def connect(self, addr):
        out = super().connect(addr)
        if self.type == zmq.REQ:
            wait_until(  # the refusal: a state of the socket, polled
                lambda: not self.getsockopt(zmq.EVENTS) & zmq.POLLOUT,
                "the daemon refused the handshake",
                timeout=30,
                interval=0.001,
            )
        return out


class _RefusedFirstContext(zmq.Context):
    _socket_class = _RefusedFirst


def test_a_key_refused_before_the_request_is_sent_is_said_at_once(secure_daemon, keys, tmp_path):
    """The refusal of a stranger's key can come before :func:`request` sends (a loaded
    machine): it is still said, not waited out as a timeout (a blocking send did that: the
    refused connection takes no message, and the monitor that said why was not read)."""
    _, ep = secure_daemon()
    generate(tmp_path / "stranger")
    own = ClientKeys.load(tmp_path / "stranger")
    stranger = ClientKeys(own.public, own.secret, ClientKeys.load(keys).server)
    ctx = _RefusedFirstContext()
    try:
        with pytest.raises(ConnectionRefusedError, match="refused this client's CURVE key"):
            request(ep["control"], "ping", ctx=ctx, curve=stranger, timeout=30)
    finally:
        ctx.destroy(linger=0)


def test_a_secret_key_readable_by_others_is_warned_about(tmp_path, caplog):
    """`keys` writes secrets 0600; a copy that lost that mode still loads, with a warning
    naming the file and the fix."""
    generate(tmp_path)
    secret = tmp_path / "client.key_secret"
    with caplog.at_level("WARNING", logger="streamseg.security"):
        ClientKeys.load(tmp_path)
    assert not caplog.records  # as written by `keys`
    secret.chmod(0o644)
    with caplog.at_level("WARNING", logger="streamseg.security"):
        ClientKeys.load(tmp_path)
    assert len(caplog.records) == 1
    msg = caplog.records[0].getMessage()
    assert str(secret) in msg and "644" in msg and f"chmod 600 {secret}" in msg


def test_a_daemon_that_tears_every_handshake_is_a_refusal_not_a_timeout():
    """A CURVE daemon may close a client without CURVE before the client has read its
    greeting: the client then sees only torn handshakes (no PROTOCOL event), at each
    reconnection. A peer that does that every time must be reported as a refusal, at once,
    not as a daemon that never answered (the 30 s timeout)."""
    import socket
    import threading

    server = socket.create_server(("127.0.0.1", 0))
    stop = threading.Event()

    def tear():
        while not stop.is_set():
            conn, _ = server.accept()
            conn.recv(10)  # the start of the ZMTP greeting, then hang up mid-handshake
            conn.close()

    threading.Thread(target=tear, daemon=True).start()
    endpoint = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    try:
        with pytest.raises(ConnectionRefusedError, match="it has CURVE on"):
            request(endpoint, "ping", timeout=60)
    finally:
        stop.set()
        server.close()
