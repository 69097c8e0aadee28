"""The daemon over real ZeroMQ sockets on loopback (in-process; SIGTERM in test_daemon_signal)."""

from __future__ import annotations

import threading
import time

import msgpack
import numpy as np
import pytest
import zmq

from streamseg import protocol as P
from streamseg.client import listen, request, subscribe
from streamseg.commands.replay import announce_of, replay
from streamseg.config import DaemonConfig
from streamseg.daemon import Daemon
from streamseg.daemon.algorithms import Algorithms
from streamseg.exceptions import ParameterError
from streamseg.io import read
from streamseg.io.gaps import fill_gaps
from streamseg.online.lof import StreamingLOFSegmenter
from tests.motion import lof_input
from tests.waiting import wait_until

pytestmark = pytest.mark.daemon
LOOP = "tcp://127.0.0.1:0"


def offline_cuts(rec, positions=None):
    """Cut frames of the streaming segmenter run over the whole file in one call."""
    seg = StreamingLOFSegmenter(fps=rec.fps)
    ang = lof_input(rec.positions if positions is None else positions, rec.skeleton, rec.fps)
    return [c.frame for c in seg.learn_many(ang) + seg.finish()]


def sub(ep, **kw):
    return subscribe(ep["publish"], ep["control"], **kw)  # a handshake, not a sleep


def push(ep):
    ctx = zmq.Context.instance()
    s = ctx.socket(zmq.PUSH)
    s.setsockopt(zmq.LINGER, 5000)
    s.connect(ep["ingest"])
    return s


def cuts_of(events, stream):
    """The detector's cuts (provisional); a relabel announces the others (Settled cuts)."""
    return [e.frame for e in events if e.type == "cut" and e.stream == stream and e.provisional]


def test_replay_gives_offline_cuts_and_relabels(start_daemon, rec):
    d, ep = start_daemon(relabel_interval=5.0, relabel_history=10.0)
    s = sub(ep, stream="r1")
    replay(rec, ep["ingest"], stream="r1", speed=0, batch=7)
    events = list(listen(s, stream="r1", until_end=True, timeout=30))
    want = offline_cuts(rec)
    assert len(want) >= 3
    assert cuts_of(events, "r1") == want
    segs = [e for e in events if e.type == "segments"]
    assert segs and segs[-1].final and events[-1].type == "closed"
    assert [e.revision for e in segs] == list(range(1, len(segs) + 1))
    for e in segs:  # each relabel tiles its window exactly, inside the recording
        assert e.segments[0][0] == e.start and e.segments[-1][1] == e.end <= rec.n_frames
        assert all(a[1] == b[0] for a, b in zip(e.segments, e.segments[1:], strict=False))
        assert e.end - e.start <= 10 * 120
    assert segs[-1].end == rec.n_frames


def test_announced_up_axis_reaches_the_features(start_daemon, rec):
    """A Z-up copy of 86_01 announced with up="z" is cut exactly like the Y-up original;
    announced with the default "y" it is not (the inclinations read the declared axis)."""
    from dataclasses import replace as dc_replace

    x, y, z = (rec.positions[..., i] for i in range(3))
    z_up = np.stack([x, -z, y], axis=-1)
    declared = dc_replace(rec, positions=z_up, skeleton=dc_replace(rec.skeleton, up="z"))
    undeclared = dc_replace(rec, positions=z_up)
    d, ep = start_daemon()
    s = sub(ep)
    replay(declared, ep["ingest"], stream="z", speed=0, batch=60)
    replay(undeclared, ep["ingest"], stream="wrong", speed=0, batch=60)
    events, closed = [], set()
    for e in listen(s, timeout=30):
        events.append(e)
        closed |= {e.stream} if e.type == "closed" else set()
        if closed >= {"z", "wrong"}:
            break
    want = offline_cuts(rec)
    assert cuts_of(events, "z") == want
    assert cuts_of(events, "wrong") != want
    # the undeclared stream is told, once, which axis its body stands along; it goes on
    warned = [e for e in events if e.type == "error" and e.reason == "up"]
    assert [e.stream for e in warned] == ["wrong"] and "'z'" in warned[0].message
    assert not [e for e in events if e.type == "error" and e.stream == "z"]


def test_two_interleaved_streams(start_daemon, rec):
    d, ep = start_daemon()
    s = sub(ep)
    sock = push(ep)
    half = rec.slice(1000, rec.n_frames)
    for r, name in ((rec, "a"), (half, "b")):
        sock.send_multipart(P.encode(announce_of(r, name)))
    # packets of both streams alternate on one socket, with different packet sizes
    pa = [(a, rec.positions[a : a + 5]) for a in range(0, rec.n_frames, 5)]
    pb = [(a, half.positions[a : a + 12]) for a in range(0, half.n_frames, 12)]
    for i in range(max(len(pa), len(pb))):
        for name, packets in (("a", pa), ("b", pb)):
            if i < len(packets):
                sock.send_multipart(P.encode(P.Frames(name, packets[i][0], 0.0, packets[i][1])))
    for name in "ab":
        sock.send_multipart(P.encode(P.End(name)))
    sock.close()
    events, closed = [], set()
    for e in listen(s, timeout=30):
        events.append(e)
        closed |= {e.stream} if e.type == "closed" else set()
        if closed == {"a", "b"}:
            break
    assert cuts_of(events, "a") == offline_cuts(rec)
    assert cuts_of(events, "b") == offline_cuts(half)


def test_garbage_between_good_packets(start_daemon, rec):
    d, ep = start_daemon()
    s = sub(ep)
    sock = push(ep)
    pos = rec.positions.copy()
    sock.send_multipart(P.encode(announce_of(rec, "g")))
    garbage = {
        "decode": [b"frames/g/", b"\xc1\xc1 not msgpack"],
        "version": [b"frames/g/", msgpack.packb({"v": 0, "type": "frames", "stream": "g"})],
        "field": [b"frames/g/", msgpack.packb({"v": 1, "type": "frames", "stream": "g"})],
        "unknown_stream": P.encode(P.Frames("nobody", 0, 0.0, pos[:2])),
        "type": [b"frames/g/", msgpack.packb({"v": 1, "type": [1], "stream": "g"})],
        "huge_seq": P.encode(P.Frames("g", 2**60, 0.0, pos[:2])),  # a "field" error
    }
    nan_rows = np.arange(2010, 2070)  # 0.5 s without positions: a gap the detectors skip
    pos[nan_rows] = np.nan
    pos[2500:2506] = np.nan  # 0.05 s: filled by interpolation, as a file's would be
    step, n_garbage, n_bad_arrays, n_dups = 10, 0, 0, 0
    for a in range(0, rec.n_frames, step):
        if a == 3000:
            continue  # a lost packet: frames 3000..3009 never arrive (a gap)
        sock.send_multipart(P.encode(P.Frames("g", a, 0.0, pos[a : a + step])))
        if a % 500 == 0:
            for parts in garbage.values():
                sock.send_multipart(parts)
            n_garbage += 1
            wrong = P.Frames("g", a + step, 0.0, pos[a : a + step, :5])  # 5 joints, not 31
            sock.send_multipart(P.encode(wrong))
            n_bad_arrays += 1
        if a % 700 == 0 and a:
            sock.send_multipart(P.encode(P.Frames("g", a, 0.0, pos[a : a + step])))  # duplicate
            n_dups += 1
    sock.send_multipart(P.encode(P.End("g")))
    sock.close()
    events = list(listen(s, stream="g", until_end=True, timeout=30))
    ref = pos.copy()
    ref[3000:3010] = np.nan  # the offline run sees the lost frames as missing
    ref, report = fill_gaps(ref, rec.fps)  # ... and fills its short gaps the same way
    assert report.gaps == [(2010, 2070)]
    assert cuts_of(events, "g") == offline_cuts(rec, ref)
    stats = request(ep["control"], "stats")["totals"]["errors_by_reason"]
    assert stats == {
        "decode": n_garbage,
        "version": n_garbage,
        "field": 2 * n_garbage,
        "type": n_garbage,
        "unknown_stream": n_garbage,
        "array": n_bad_arrays,
        "duplicate": n_dups * step,
        "nan": len(nan_rows),
        "gap": 1,
    }
    gaps = [e for e in events if e.type == "gap"]
    assert [(e.expected, e.got, e.filled) for e in gaps] == [
        (2010, 2070, False),
        (3000, 3010, True),
    ]
    errors = [e for e in events if e.type == "error" and e.stream == "g"]
    assert {e.reason for e in errors} >= {"array", "duplicate", "nan", "version", "field"}


def test_late_listener_catches_up_from_control(start_daemon, rec):
    d, ep = start_daemon(relabel_interval=2.0, relabel_history=6.0, heartbeat=0)
    early = sub(ep, stream="late")
    sock = push(ep)
    sock.send_multipart(P.encode(announce_of(rec, "late")))
    n1 = 2600
    for a in range(0, n1, 20):
        sock.send_multipart(P.encode(P.Frames("late", a, 0.0, rec.positions[a : a + 20])))
    seen = []
    for e in listen(early, timeout=20):
        seen.append(e)
        if e.type == "segments" and e.end >= n1 - 2 * 120:
            break
    wait_until(
        lambda: (
            (st := request(ep["control"], "state", stream="late"))["frame"] == n1
            and st["revision"] >= 1
        ),
        f"frame {n1} taken and a relabel in the state",
    )
    late = sub(ep, stream="late")
    state = request(ep["control"], "state", stream="late")
    assert state["ok"] and state["frame"] == n1
    # the snapshot is the newest relabel with its revision, plus the cuts after it
    early_segs = [e for e in seen if e.type == "segments"]
    while not early_segs or early_segs[-1].revision < state["revision"]:
        e = next(listen(early, timeout=10))
        seen.append(e)
        early_segs = [x for x in seen if x.type == "segments"]
    same = [e for e in early_segs if e.revision == state["revision"]][0]
    assert state["segments"] == P.to_json(same)
    assert [c["frame"] for c in state["cuts"]] == [
        e.frame for e in seen if e.type == "cut" and e.frame >= same.end
    ]
    # then it gets the updates: revisions continue from the snapshot's
    for a in range(n1, rec.n_frames, 20):
        sock.send_multipart(P.encode(P.Frames("late", a, 0.0, rec.positions[a : a + 20])))
    sock.send_multipart(P.encode(P.End("late")))
    sock.close()
    later = list(listen(late, stream="late", until_end=True, timeout=20, since=state))
    revs = [e.revision for e in later if e.type == "segments"]
    assert revs and revs[0] == state["revision"] + 1 and revs == sorted(revs)


@pytest.mark.slow
def test_ingest_does_not_wait_for_a_long_relabel(start_daemon, rec):
    """A relabel that holds the GIL in pure Python until a cut is published: the cut comes
    (ingest and the cut detector go on beside it), and the relabel then ends."""
    serving, started, arrivals, during = threading.Event(), threading.Event(), [], []

    def slow_relabel(features, *, start_frame, fps, config, previous):
        from streamseg.config import ACAConfig
        from streamseg.offline import relabel_window

        # the first job of the stream (not the daemon's warm-up call before it serves): it
        # runs until a cut arrives meanwhile
        if serving.is_set() and not started.is_set():
            before = len(arrivals)
            started.set()
            deadline, x = time.monotonic() + 120, 0
            while len(arrivals) == before and time.monotonic() < deadline:
                x += 1  # pure Python: holds the GIL between switches
            during.extend(arrivals[before:])
        return relabel_window(
            features, start_frame=start_frame, fps=fps, config=ACAConfig(), previous=previous
        )

    d, ep = start_daemon(
        Algorithms(relabel=slow_relabel), relabel_interval=1.0, relabel_history=4.0
    )
    serving.set()
    s = sub(ep, stream="slow")

    def collect():
        for e in listen(s, stream="slow", until_end=True, timeout=60):
            if e.type == "cut" and e.provisional:  # the detector's, not a relabel's
                arrivals.append(e.frame)

    t = threading.Thread(target=collect)
    t.start()
    sock = push(ep)
    sock.send_multipart(P.encode(announce_of(rec, "slow")))
    split = 2400  # cuts at 2502, 3276 and 4066 come after it
    for a in range(0, split, 20):
        sock.send_multipart(P.encode(P.Frames("slow", a, 0.0, rec.positions[a : a + 20])))
    assert started.wait(60), "no relabel ran"
    for a in range(split, rec.n_frames, 20):  # sent while the first relabel runs
        sock.send_multipart(P.encode(P.Frames("slow", a, 0.0, rec.positions[a : a + 20])))
    sock.send_multipart(P.encode(P.End("slow")))
    sock.close()
    t.join(120)
    assert not t.is_alive()
    assert arrivals == offline_cuts(rec)
    assert during, f"no cut arrived while the relabel ran: {arrivals}"


def _final_job_bytes(rec, history: float) -> int:
    """Bytes the final relabel job of a take of ``rec`` holds (features and frame numbers)."""
    from streamseg.daemon.pipeline import StreamPipeline

    pipe = StreamPipeline(rec.skeleton, rec.fps, Algorithms(), history)
    pipe.push(rec.positions, 0)
    pipe.finish()
    feats, frames, _ = pipe.relabel_snapshot(True)
    return feats.nbytes + frames.nbytes


def _gated_relabel(gate, armed, starts=None):
    """A relabel that, once ``armed`` (after the daemon's warm-up), waits for ``gate`` (the
    worker is behind until the test lets it go), recording each job's first frame in
    ``starts``."""

    def relabel(features, *, start_frame, fps, config, previous):
        from streamseg.config import ACAConfig
        from streamseg.offline import relabel_window

        if armed.is_set():
            if starts is not None:
                starts.append(start_frame)
            if isinstance(gate, threading.Event):
                gate.wait(60)
            else:
                gate.acquire(timeout=60)
        return relabel_window(
            features, start_frame=start_frame, fps=fps, config=ACAConfig(), previous=previous
        )

    return relabel


def test_takes_waiting_for_their_final_relabel_are_bounded_in_bytes(start_daemon, rec):
    """Takes that end faster than the worker relabels wait for their final relabel, each
    holding the snapshot of its history (its detector state freed); beyond
    ``final_relabel_bytes`` a take closes at once without it (its live cuts stand, an error
    says why): memory stays bounded."""
    gate, armed = threading.Event(), threading.Event()
    part = rec.slice(0, 240)
    per_take = _final_job_bytes(part, 2.0)
    waiting = 4
    limit = waiting * per_take + per_take // 2
    d, ep = start_daemon(
        Algorithms(relabel=_gated_relabel(gate, armed)),
        relabel_interval=60.0,
        relabel_history=2.0,
        final_relabel_bytes=limit,
    )
    armed.set()
    n = waiting + 6
    s = sub(ep)
    for k in range(n):
        replay(part, ep["ingest"], stream=f"t{k}", speed=0, batch=120)
    try:
        events, closed = [], []
        # while the worker is held only the skipped takes close; the last one surely is
        for e in listen(s, timeout=30):
            events.append(e)
            if e.type == "closed":
                closed.append(e.stream)
                if e.stream == f"t{n - 1}":
                    break
        kept = n - len(closed)
        # the first take's job may have gone to the worker before the next ones ended
        assert kept in (waiting, waiting + 1), closed
        assert closed == [f"t{k}" for k in range(kept, n)]
        assert len(d.closing) == kept
        assert d.relabels.final_bytes <= limit
    finally:
        gate.set()  # the worker goes on, pass or fail (the daemon must stop)
    for e in listen(s, timeout=30):
        events.append(e)
        if e.type == "closed":
            closed.append(e.stream)
            if len(closed) == n:
                break
    assert sorted(closed) == sorted(f"t{k}" for k in range(n))
    assert d.relabels.final_bytes == 0 and not d.closing
    for k in range(n):
        mine = [e for e in events if getattr(e, "stream", None) == f"t{k}"]
        final = [e for e in mine if e.type == "segments" and e.final]
        skipped = [e for e in mine if e.type == "error" and e.reason == "relabel"]
        assert mine[-1].type == "closed"
        if k < kept:
            assert len(final) == 1 and not skipped
        else:
            assert not final and len(skipped) == 1 and "final relabel skipped" in skipped[0].message


def test_a_backlog_of_final_relabels_does_not_stop_live_revisions(start_daemon, rec):
    """The worker's free slots go to ended takes' final relabels and live streams' revisions
    in turn: a live stream is relabelled before the backlog of finals is through."""
    gate, armed = threading.Semaphore(0), threading.Event()  # one relabel per release
    starts = []  # each job's first frame: the ended takes' are 0, the live stream's later
    d, ep = start_daemon(
        Algorithms(relabel=_gated_relabel(gate, armed, starts)),
        relabel_interval=1.0,
        relabel_history=2.0,
    )
    armed.set()
    s = sub(ep)
    n = 4
    part = rec.slice(0, 240)
    try:
        for k in range(n):
            replay(part, ep["ingest"], stream=f"t{k}", speed=0, batch=120)
        wait_until(lambda: len(d.closing) == n, "the ended takes wait for their finals", 30)
        sock = push(ep)
        sock.send_multipart(P.encode(announce_of(rec, "live")))
        for a in range(1000, 1600, 40):  # 5 s of frames: the ring holds the last 2 s
            sock.send_multipart(
                P.encode(P.Frames("live", a - 1000, 0.0, rec.positions[a : a + 40]))
            )
        wait_until(
            lambda: "live" in d.streams and d.streams["live"].next_seq == 600,
            "the live stream's frames are in",
            30,
        )
        for _ in range(n + 3):  # the finals and a few live revisions
            gate.release()
        finals_done = []
        for e in listen(s, timeout=30):
            if e.type == "segments" and e.final:
                finals_done.append(e.stream)
                if len(finals_done) == n:
                    break
        live = [i for i, a in enumerate(starts) if a > 0]
        assert live, f"no live relabel ran: {starts}"
        assert live[0] < n, f"the live stream waited behind every final relabel: {starts}"
        sock.send_multipart(P.encode(P.End("live")))
        sock.close()
    finally:
        for _ in range(100):  # the daemon must stop, pass or fail
            gate.release()


def test_limits_max_streams_and_idle(start_daemon, rec):
    d, ep = start_daemon(max_streams=1, idle_timeout=0.5)
    s = sub(ep)
    sock = push(ep)
    sock.send_multipart(P.encode(announce_of(rec, "one")))
    sock.send_multipart(P.encode(announce_of(rec, "two")))
    sock.send_multipart(P.encode(P.Frames("one", 0, 0.0, rec.positions[:10])))
    events = []
    for e in listen(s, timeout=5):
        events.append(e)
        if e.type == "closed":
            break
    err = [e for e in events if e.type == "error"]
    # 10 frames are fewer than one detector window: that is said too, before `closed`
    assert [(e.stream, e.reason) for e in err] == [("two", "max_streams"), ("one", "short")]
    assert events[-1] == P.Closed("one", "idle", 10)
    assert request(ep["control"], "streams")["streams"] == []
    sock.close()


def test_control_requests(start_daemon):
    d, ep = start_daemon()
    assert request(ep["control"], "ping")["ok"]
    bad = request(ep["control"], "dance")
    assert not bad["ok"] and "unknown op 'dance'" in bad["error"]
    assert "no stream 'x'" in request(ep["control"], "state", stream="x")["error"]
    ctx = zmq.Context.instance()
    req = ctx.socket(zmq.REQ)
    req.connect(ep["control"])
    req.send(msgpack.packb({"v": 0, "op": "ping"}))
    old = msgpack.unpackb(req.recv(), raw=False)
    req.close(linger=0)
    assert not old["ok"] and "protocol version 0" in old["error"]
    assert request(ep["control"], "shutdown")["ok"]
    assert d._stop.is_set()
    for t in [t for t in threading.enumerate() if t.name == "streamseg-daemon-under-test"]:
        t.join(15)
        assert not t.is_alive(), "the shutdown request did not stop the daemon"


@pytest.mark.slow
def test_live_repetitions_match_the_counter(start_daemon, data_dir):
    from streamseg.online import RepetitionCounter

    rec = read(data_dir / "cmu_exercise" / "14_14.amc.gz", skeleton=data_dir / "cmu86" / "86.asf")
    rec = rec.slice(0, 1800)  # 15 s: jumping jacks
    d, ep = start_daemon(Algorithms(repetitions=True))
    s = sub(ep, stream="reps")
    replay(rec, ep["ingest"], stream="reps", speed=0, batch=30)
    events = list(listen(s, stream="reps", until_end=True, timeout=60))
    counter = RepetitionCounter(fps=rec.fps, skeleton=rec.skeleton)
    want = counter.learn_many(rec.positions) + counter.finish()
    got = [(e.start, e.end, e.count, e.emitted_at) for e in events if e.type == "rep"]
    assert len(want) >= 3
    assert got == [(r.start, r.end, r.count, r.emitted_at) for r in want]


@pytest.mark.slow
def test_relabel_in_a_process_pool(start_daemon, rec):
    d, ep = start_daemon(relabel_interval=5.0, relabel_history=10.0, relabel_processes=1)
    s = sub(ep, stream="pp")
    replay(rec, ep["ingest"], stream="pp", speed=0, batch=60)
    events = list(listen(s, stream="pp", until_end=True, timeout=60))
    assert cuts_of(events, "pp") == offline_cuts(rec)
    segs = [e for e in events if e.type == "segments"]
    assert segs and segs[-1].final and segs[-1].end == rec.n_frames
    assert all(e.segments[0][0] == e.start and e.segments[-1][1] == e.end for e in segs)


def test_default_skeleton_opens_streams_on_first_packet(start_daemon, rec, data_dir):
    d, ep = start_daemon(default_skeleton=str(data_dir / "cmu86" / "86.asf"))
    s = sub(ep, stream="anon")
    sock = push(ep)
    for a in range(0, rec.n_frames, 40):  # no announce message
        sock.send_multipart(P.encode(P.Frames("anon", a, 0.0, rec.positions[a : a + 40])))
    sock.send_multipart(P.encode(P.End("anon")))
    sock.close()
    events = list(listen(s, stream="anon", until_end=True, timeout=30))
    assert cuts_of(events, "anon") == offline_cuts(rec)
    assert not [e for e in events if e.type == "error"]


def test_default_skeleton_takes_the_configured_up_axis(start_daemon, rec, data_dir):
    """Unannounced Z-up frames are cut like the Y-up original with default_up = "z"."""
    x, y, z = (rec.positions[..., i] for i in range(3))
    z_up = np.stack([x, -z, y], axis=-1)
    d, ep = start_daemon(default_skeleton=str(data_dir / "cmu86" / "86.asf"), default_up="z")
    s = sub(ep, stream="anon")
    sock = push(ep)
    for a in range(0, rec.n_frames, 60):
        sock.send_multipart(P.encode(P.Frames("anon", a, 0.0, z_up[a : a + 60])))
    sock.send_multipart(P.encode(P.End("anon")))
    sock.close()
    events = list(listen(s, stream="anon", until_end=True, timeout=30))
    assert cuts_of(events, "anon") == offline_cuts(rec)
    with pytest.raises(ParameterError, match="default_up"):
        DaemonConfig(default_up="up")


def test_failed_start_still_shuts_down():
    """A daemon whose start fails (here: warmup) must close every socket and return,
    including the receiver's wake-up socket that its never-started thread would close."""

    class Broken(Algorithms):
        def warmup(self, relabel: bool = True) -> float:
            raise RuntimeError("warmup failed")

    d = Daemon(
        DaemonConfig(ingest=LOOP, publish=LOOP, control=LOOP, relabel_interval=0, heartbeat=0),
        Broken(),
    )
    d.bind()
    box = {}

    def run():
        try:
            box["rc"] = d.run()
        except Exception as err:  # the failure itself is expected
            box["err"] = err

    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(20)
    assert not t.is_alive(), "the daemon hung in shutdown"
    # the failure reaches the caller, and every socket is closed behind it
    assert isinstance(box.get("err"), RuntimeError) and "warmup failed" in str(box["err"])
    assert "rc" not in box
    assert d.ingest.sock.closed and d.ingest.wake.closed and d.pub.closed and d.control.sock.closed


def test_control_answers_while_a_lossy_burst_is_processed(start_daemon, rec):
    """A sender with a frame missing before every packet makes the daemon run the pipeline
    once per packet (a gap each). The loop works through such a backlog in slices, answering
    control requests between them: replies during the burst show the stream part-way, where
    one loop pass over the whole queue answered only once it was done."""
    d, ep = start_daemon()
    sock = push(ep)
    sock.send_multipart(P.encode(announce_of(rec, "lossy")))
    last = 4000
    for a in range(0, last, 2):
        sock.send_multipart(P.encode(P.Frames("lossy", a, a / rec.fps, rec.positions[a : a + 1])))
    sock.send_multipart(P.encode(P.End("lossy")))
    sock.close(linger=10_000)
    seen = []
    while True:
        state = request(ep["control"], "state", stream="lossy")
        if state.get("closed"):
            break
        if state.get("ok"):
            seen.append(state["frame"])
    assert any(0 < f < last - 1 for f in seen), seen
    assert d.streams == {} and state["frame"] == last - 1
