"""Lab Streaming Layer in and out, with real liblsl outlets and inlets kept on this machine:
the tests write an lsl_api.cfg (machine scope, loopback, IPv6 off, their own ports and
session id) and point LSLAPICFG at it before liblsl starts, in this process and in the
`streamseg serve` / `streamseg lsl` subprocesses."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
import uuid

import numpy as np
import pytest

from streamseg.cli import main
from streamseg.client import request
from tests.cli_words import FREE_PORTS, STREAMSEG
from tests.waiting import wait_until

pytestmark = pytest.mark.daemon


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def lsl(tmp_path_factory):
    """pylsl, configured to stay on this machine (a session of its own)."""
    cfg = tmp_path_factory.mktemp("lsl") / "lsl_api.cfg"
    base = _free_port()
    cfg.write_text(f"""[ports]
IPv6 = disable
MulticastPort = {_free_port()}
BasePort = {base}
PortRange = 64

[multicast]
ResolveScope = machine
MachineAddresses = {{127.0.0.1}}
ListenAddress = 127.0.0.1

[lab]
SessionID = streamseg-test-{uuid.uuid4().hex[:12]}
KnownPeers = {{127.0.0.1}}

[log]
level = -3
""")
    os.environ["LSLAPICFG"] = str(cfg)
    pylsl = pytest.importorskip("pylsl")
    return pylsl


def outlet_of(pylsl, rec, source_id: str, fmt=None):
    from streamseg.lsl.meta import add_channels

    n = rec.skeleton.n_joints
    info = pylsl.StreamInfo(
        "mocap-test", "MoCap", 3 * n, rec.fps, fmt or pylsl.cf_double64, source_id
    )
    add_channels(info.desc(), rec.skeleton.names, "millimeters")
    return pylsl.StreamOutlet(info, chunk_size=0, max_buffered=600)


def push_take(out, positions, fps, t0, first=0, step=60):
    flat = positions.reshape(positions.shape[0], -1)
    for a in range(0, flat.shape[0], step):
        stamps = (t0 + (first + a + np.arange(min(step, flat.shape[0] - a))) / fps).tolist()
        out.push_chunk(flat[a : a + step].tolist(), stamps)


def serve(*extra):
    """`streamseg serve` on free loopback ports; returns (process, endpoints)."""
    cmd = [
        *STREAMSEG,
        "serve",
        *FREE_PORTS,
        "--state-dir",
        "none",
        *extra,
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = proc.stdout.readline()
    assert line.startswith("streamseg serve: ingest="), line + proc.stderr.read()
    endpoints = dict(kv.split("=", 1) for kv in line.split(": ", 1)[1].split())
    return proc, endpoints


def wait_frames(control, stream, n, timeout=60.0):
    """Wait until the daemon has taken ``n`` frames of ``stream`` (its control reply)."""
    wait_until(
        lambda: any(
            s["stream"] == stream and s["frame"] >= n
            for s in request(control, "streams")["streams"]
        ),
        f"{stream} reached {n} frames",
        timeout,
    )


def pull_markers(inlet, want_closed: str, timeout=30.0):
    out = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        samples, stamps = inlet.pull_chunk(timeout=0.5)
        for s, t in zip(samples, stamps):
            ev = json.loads(s[0])
            out.append((ev, t))
            if ev["type"] == "closed" and ev["stream"] == want_closed:
                return out
    raise TimeoutError(f"no closed marker of {want_closed}: {[e['type'] for e, _ in out]}")


def test_stream_description_to_joints(lsl):
    from streamseg.exceptions import ParameterError
    from streamseg.lsl.meta import add_channels, stream_skeleton

    info = lsl.StreamInfo("k", "MoCap", 9, 30, lsl.cf_float32, "k1")
    add_channels(info.desc(), ["SpineBase", "HipLeft", "KneeLeft"], "meters")
    sk = stream_skeleton(info.as_xml())
    assert sk.names == ("SpineBase", "HipLeft", "KneeLeft") and sk.units == "meters"
    assert sk.columns == ((0, 1, 2), (3, 4, 5), (6, 7, 8))
    bare = lsl.StreamInfo("bare", "MoCap", 6, 30, lsl.cf_float32, "b1")
    with pytest.raises(ParameterError, match=r"'bare' .* no channel description.*PositionX"):
        stream_skeleton(bare.as_xml())
    half = lsl.StreamInfo("half", "MoCap", 2, 30, lsl.cf_float32, "h1")
    chans = half.desc().append_child("channels")
    for axis in "XY":
        ch = chans.append_child("channel")
        ch.append_child_value("label", f"LKNE_{axis}")
        ch.append_child_value("type", f"Position{axis}")
    with pytest.raises(ParameterError, match=r"without all of x, y, z: LKNE \(has xy\)"):
        stream_skeleton(half.as_xml())


def test_an_lsl_take_gives_the_cuts_of_the_file_and_lsl_markers(
    lsl, rec, data_dir, capsys, tmp_path
):
    """86_01 played into an LSL outlet -> `streamseg lsl` -> `streamseg serve --lsl-markers`:
    the cuts of `segment --online` on the file, and every one of them on the marker stream,
    stamped with the LSL time of its frame."""
    amc, asf = data_dir / "cmu86" / "86_01.amc.gz", data_dir / "cmu86" / "86.asf"
    assert main(["segment", str(amc), "--skeleton", str(asf), "--online", "--json"]) == 0
    want = json.loads(capsys.readouterr().out)["cuts"]
    assert len(want) >= 5

    source = f"take-{uuid.uuid4().hex[:8]}"
    proc, ep = serve("--lsl-markers", "--relabel-interval", "30")
    bridge = None
    try:
        assert "LSL marker stream" in proc.stdout.readline()
        found = lsl.resolve_bypred(
            f"type='Markers' and source_id='streamseg-events-{ep['publish']}'", 1, 20.0
        )
        assert found, "the daemon's marker stream was not found"
        markers = lsl.StreamInlet(found[0], processing_flags=lsl.proc_clocksync)
        markers.open_stream(10.0)
        out = outlet_of(lsl, rec, source)
        bridge = subprocess.Popen(
            [
                *STREAMSEG,
                "lsl",
                "--to",
                ep["ingest"],
                "--source-id",
                source,
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        assert "waiting for LSL streams" in bridge.stdout.readline()
        while not out.wait_for_consumers(0.5):
            assert bridge.poll() is None, bridge.stderr.read()
        t0 = lsl.local_clock()
        push_take(out, rec.positions, rec.fps, t0)
        opened = bridge.stdout.readline()
        assert f"-> stream {source}" in opened and "31 joints at 120 Hz, up y" in opened
        wait_frames(ep["control"], source, rec.n_frames)
        bridge.send_signal(signal.SIGTERM)  # ends the stream: the last cuts come out
        assert bridge.wait(30) == 0
        got = pull_markers(markers, source)
    finally:
        if bridge is not None and bridge.poll() is None:
            bridge.kill()
        proc.send_signal(signal.SIGTERM)
        proc.wait(30)
    # the detector's cuts (a relabel announces others, provisional false: Settled cuts)
    cuts = [
        (e, t)
        for e, t in got
        if e["type"] == "cut" and e["stream"] == source and e.get("provisional", True)
    ]
    assert [e["frame"] for e, _ in cuts] == want
    for ev, stamp in cuts:  # the LSL time of the cut's frame, as the outlet stamped it
        assert stamp == pytest.approx(t0 + ev["frame"] / rec.fps, abs=1e-3)
        # (LSL clock sync between two processes of one machine: microseconds)
        assert ev["time"] == pytest.approx(t0 + ev["frame"] / rec.fps, abs=1e-3)
    segs = [e for e, _ in got if e["type"] == "segments"]
    assert segs and segs[-1]["final"]
    closed = [(e, t) for e, t in got if e["type"] == "closed"][-1]
    assert closed[0]["frames"] == rec.n_frames
    assert closed[1] == pytest.approx(t0 + rec.n_frames / rec.fps, abs=1e-3)


def test_serve_follows_an_outlet_that_comes_back(lsl, rec):
    """`serve --lsl-type MoCap`: frames of an outlet that goes away and comes back (same
    source id) continue the stream; the missing frames are a gap."""
    source = f"back-{uuid.uuid4().hex[:8]}"
    proc, ep = serve("--lsl-type", "MoCap", "--lsl-source-id", source, "--relabel-interval", "0")
    try:
        out = outlet_of(lsl, rec, source)
        t0 = lsl.local_clock()
        deadline = time.monotonic() + 30
        while not out.wait_for_consumers(0.5):
            assert time.monotonic() < deadline and proc.poll() is None
        push_take(out, rec.positions[:1200], rec.fps, t0)
        wait_frames(ep["control"], source, 1200)
        del out  # the mocap system stops ...
        out = outlet_of(lsl, rec, source)  # ... and comes back, 2 s of frames later
        deadline = time.monotonic() + 30
        while not out.wait_for_consumers(0.5):
            assert time.monotonic() < deadline and proc.poll() is None
        push_take(out, rec.positions[1440:2400], rec.fps, t0, first=1440)
        wait_frames(ep["control"], source, 2400)
        stats = request(ep["control"], "stats")["streams"][source]
        assert stats["lost"] == 240 and stats["frames_in"] == 2160
    finally:
        proc.send_signal(signal.SIGTERM)
        proc.wait(30)


def test_lsl_without_pylsl_or_streams_says_so(tmp_path):
    run = subprocess.run(
        [sys.executable, "-m", "streamseg.cli", "lsl", "--to", "nowhere"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 2 and "tcp://HOST:PORT" in run.stderr


def test_lsl_input_sends_markers_as_the_joints_of_the_map(lsl, start_daemon, rec, tmp_path):
    """An LSL stream whose channels are markers, through `streamseg lsl --markers MAP.toml`:
    the daemon gets the map's joints, and gives the events of a stream that sends them."""
    from streamseg.client import subscribe
    from streamseg.lsl.meta import add_channels
    from streamseg.skeleton.marker_sets import JOINTS
    from tests.test_marker_map_live import events_of, marker_take, send

    joints, names, markers, toml = marker_take(rec, 2400)
    (tmp_path / "map.toml").write_text(toml)
    d, ep = start_daemon(relabel_interval=0)
    source = f"mk-{uuid.uuid4().hex[:8]}"
    subs = {s: subscribe(ep["publish"], ep["control"], stream=s) for s in (source, "j")}
    info = lsl.StreamInfo("markers-test", "MoCap", 3 * len(names), rec.fps, lsl.cf_double64, source)
    add_channels(info.desc(), names, "m")
    out = lsl.StreamOutlet(info, chunk_size=0, max_buffered=600)
    bridge = subprocess.Popen(
        [
            *STREAMSEG,
            "lsl",
            "--to",
            ep["ingest"],
            "--source-id",
            source,
            "--up",
            "y",
            "--markers",
            str(tmp_path / "map.toml"),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert "waiting for LSL streams" in bridge.stdout.readline()
        while not out.wait_for_consumers(0.5):
            assert bridge.poll() is None, bridge.stderr.read()
        push_take(out, markers, rec.fps, lsl.local_clock())
        opened = bridge.stdout.readline()
        assert f"-> stream {source}" in opened and "16 joints at 120 Hz" in opened, opened
        wait_frames(ep["control"], source, joints.shape[0])
        bridge.send_signal(signal.SIGTERM)  # ends the stream: the last cuts come out
        assert bridge.wait(30) == 0
    finally:
        if bridge.poll() is None:
            bridge.kill()
    got = events_of(subs[source], source)
    send(ep, "j", JOINTS, joints, rec.fps)
    want = events_of(subs["j"], "j")
    cuts = [e["frame"] for e in got if e["type"] == "cut"]
    assert cuts == [e["frame"] for e in want if e["type"] == "cut"] and len(cuts) >= 2
    assert got[-1] == want[-1] == {"type": "closed", "reason": "end", "frames": 2400}
