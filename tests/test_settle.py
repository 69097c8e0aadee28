"""Provisional cuts settled by relabels: every one confirmed or withdrawn, boundaries no cut
announced become cuts, and a cut makes a relabel around it due (docs/protocol.md, Settled
cuts)."""

from __future__ import annotations

import threading

import pytest
import zmq

from streamseg import protocol
from streamseg.daemon.algorithms import Algorithms
from streamseg.daemon.options import skeleton_from
from streamseg.daemon.pipeline import StreamPipeline
from streamseg.daemon.relabel_job import relabel
from streamseg.daemon.settle import Settlement
from tests.waiting import wait_until

FPS = 100.0


def _settlement():
    # 1 s to settle, 5 s of focus, boundaries within 10 frames confirm
    return Settlement(FPS, 1.0, 5.0, 10)


def test_a_boundary_near_the_cut_confirms_it_at_the_detectors_frame():
    s = _settlement()
    s.add(500, 2.0, 700)
    assert s.due_at == 700  # emitted later than 1 s after its frame: due at once
    assert not s.due(699) and s.due(700)
    assert s.window_start() == 0  # 500 - 5 s of 100 Hz
    segs = [(0, 506, 1), (506, 900, 2)]
    out = s.apply(segs, 0, 900, False, 710)
    assert out == [(500, 2.0, 710, "confirmed", 500)]  # the detector says where
    assert s.open == [] and s.due_at == -1


def test_no_boundary_near_the_cut_withdraws_it_and_a_new_one_waits():
    s = _settlement()
    s.add(500, 2.0, 520)
    assert s.due_at == 600  # 1 s of frames after the cut
    s.add(850, 1.5, 870)
    # 850 lies in the last second of the window: not settled yet, due once 950 is in
    out = s.apply([(0, 900, 3)], 0, 900, False, 905)
    assert out == [(500, 2.0, 905, "rejected", None)]
    assert s.open == [[850, 1.5, 870]] and s.due_at == 950


def test_a_boundary_no_cut_announced_is_announced_once_two_relabels_agree():
    s = _settlement()
    segs = [(0, 300, 1), (300, 1000, 2)]
    assert s.apply(segs, 0, 1000, False, 1000) == []  # the first relabel that has it
    out = s.apply([(0, 305, 1), (305, 1100, 2)], 0, 1100, False, 1100)
    assert out == [(305, 0.0, 1100, "found", 305)]
    # settled once: a later relabel does not announce it (nor one within the radius) again
    assert s.apply([(0, 302, 1), (302, 1200, 2)], 0, 1200, False, 1200) == []


def test_the_final_relabel_settles_every_open_cut_and_announces_its_boundaries():
    s = _settlement()
    s.add(990, 1.0, 995)  # in the last second: only the final relabel can settle it
    s.add(40, 1.0, 300)  # before a window that does not start the stream: it stands
    out = s.apply([(20, 600, 1), (600, 1000, 2)], 20, 1000, True, 1000, first_frame=0)
    assert sorted(out) == [
        (40, 1.0, 1000, "confirmed", 40),
        (600, 0.0, 1000, "found", 600),
        (990, 1.0, 1000, "rejected", None),
    ]
    assert s.open == [] and s.due_at == -1


def test_same_label_segments_are_no_boundary():
    s = _settlement()
    s.add(500, 2.0, 700)
    out = s.apply([(0, 500, 1), (500, 900, 1)], 0, 900, False, 710)
    assert out == [(500, 2.0, 710, "rejected", None)]


def _drive(rec, algorithms, n_frames, history=20.0, interval=5.0, packet=40):
    """The daemon's scheduling without sockets: relabels run at once when due; returns the
    cut tuples in order and the snapshots' (first frame, focused) pairs."""
    sk = rec.skeleton
    pipe = StreamPipeline(
        skeleton_from(sk.names, sk.parents, sk.units, sk.up), rec.fps, algorithms, history
    )
    nxt = int(interval * rec.fps)
    events, windows, last = [], [], []

    def run(final):
        nonlocal nxt
        feats, frames, focused = pipe.relabel_snapshot(final or pipe.learned >= nxt)
        windows.append((int(frames[0]), focused, pipe.settlement.open[:] if focused else None))
        if not focused:
            nxt = pipe.learned + int(interval * rec.fps)
        result = relabel(algorithms, feats, frames, rec.fps, pipe.previous, tuple(pipe.cut_frames))
        events.extend(pipe.relabelled(result, final, pipe.next_frame, focused))
        last[:] = [result]

    for i in range(0, n_frames, packet):
        cuts, _, _ = pipe.push(rec.positions[i : min(i + packet, n_frames)], i)
        events.extend(cuts)
        if pipe.relabel_due(nxt):
            run(False)
    events.extend(pipe.finish())
    run(True)
    return events, windows, last[0]


def test_every_provisional_cut_of_a_real_take_is_settled_once(rec):
    """CMU 86_01's first 30 s through the daemon's pipeline: each cut the detector emitted is
    confirmed or withdrawn exactly once, by the end; a cut makes a relabel of the frames from
    focus_s before it due, which leaves the cadence alone."""
    algorithms = Algorithms(settle_s=2.0, focus_s=8.0, radius_s=1.0)
    n = 3600
    events, windows, _ = _drive(rec, algorithms, n)
    cuts = [e[0] for e in events if e[3] == "cut"]
    assert len(cuts) >= 2
    settled = [e for e in events if e[3] in ("confirmed", "rejected")]
    assert sorted(e[0] for e in settled) == sorted(cuts)
    for frame, _, emitted, kind, at in settled:
        assert emitted >= frame
        if kind == "confirmed":
            assert at == frame
    focused = [(start, open_[0][0]) for start, f, open_ in windows if f]
    assert focused
    focus = int(8.0 * rec.fps)
    # the window starts focus_s before the oldest open cut (or where the ring starts)
    assert all(oldest - focus <= start <= oldest for start, oldest in focused)
    assert any(start == oldest - focus for start, oldest in focused)


def test_every_boundary_of_the_final_relabel_is_a_settled_cut(rec):
    """The first 20 s of 86_01 (the final relabel holds the whole take): each of its action
    boundaries lies on a confirmed cut or on a cut announced for it (``found``)."""
    algorithms = Algorithms(settle_s=2.0, focus_s=8.0, radius_s=1.0)
    events, _, final = _drive(rec, algorithms, 2400, history=30.0)
    assert final.start == 0
    segs = final.segments
    bounds = [b[0] for a, b in zip(segs[:-1], segs[1:]) if a[2] != b[2]]
    assert bounds
    settled = [e[4] for e in events if e[3] in ("confirmed", "found")]
    radius = 1.0 * rec.fps
    for b in bounds:
        assert any(abs(x - b) <= radius for x in settled), (b, settled)
    assert all(e[4] == e[0] for e in events if e[3] == "found")


def _listen_until_closed(ep, stream, got, done):
    from streamseg.client import subscriber

    sub = subscriber(ep["publish"], stream=stream)

    def listen():
        while not done.is_set():
            if sub.poll(100):
                ev = protocol.decode(sub.recv_multipart())
                got.append(ev)
                if ev.type == "closed":
                    done.set()
        sub.close(0)

    th = threading.Thread(target=listen, daemon=True)
    th.start()
    return th


def _send_take(ep, rec, stream, got, done, end=True):
    """Announce and send ``rec`` as ``stream`` once the subscription is live (a probe's
    ``error`` came back through it)."""
    from streamseg.commands.replay import announce_of

    push = zmq.Context.instance().socket(zmq.PUSH)
    push.connect(ep["ingest"])

    def probed():
        push.send_multipart(protocol.encode(protocol.Frames(stream, 0, 0.0, rec.positions[:1])))
        return got

    wait_until(probed, "a probe's error came back through the subscription", interval=0.2)
    got.clear()
    push.send_multipart(protocol.encode(announce_of(rec, stream)))
    for i in range(0, rec.n_frames, 120):
        push.send_multipart(
            protocol.encode(protocol.Frames(stream, i, i / rec.fps, rec.positions[i : i + 120]))
        )
    if end:
        push.send_multipart(protocol.encode(protocol.End(stream)))
    push.close(5000)


def _check_settled(got):
    """Every provisional cut settled once, by a revision published before (or, when none
    could run, standing at the last revision); relabel-announced cuts are not provisional."""
    provisional = [e.frame for e in got if e.type == "cut" and e.provisional]
    assert provisional
    revisions, settles = {0}, {}
    for e in got:
        if e.type == "segments":
            revisions.add(e.revision)
        elif e.type in ("confirm", "withdraw") and e.revision is not None:
            assert e.revision in revisions
            assert e.frame not in settles, f"cut {e.frame} settled twice"
            settles[e.frame] = e
            if e.type == "confirm":
                assert e.settled is not None
        elif e.type == "cut" and not e.provisional:
            assert e.revision in revisions
    assert sorted(settles) == sorted(provisional)
    assert got[-1].type == "closed"
    return settles


@pytest.mark.daemon
def test_daemon_settles_every_provisional_cut_before_closed(start_daemon, rec):
    """A real daemon over loopback, relabelling on: every provisional cut of 86_01 is followed,
    before the stream's ``closed``, by exactly one ``confirm`` with its ``settled`` frame or
    one ``withdraw``, both naming a revision already published; cuts a relabel announced are
    not provisional."""
    d, ep = start_daemon(relabel_interval=5.0, relabel_history=60.0)
    got, done = [], threading.Event()
    th = _listen_until_closed(ep, "w", got, done)
    _send_take(ep, rec, "w", got, done)
    assert done.wait(300), "no closed event"
    th.join(5)
    _check_settled(got)


@pytest.mark.daemon
def test_cuts_stand_when_shutdown_leaves_no_time_for_the_final_relabel(start_daemon, rec):
    """Shutdown with ``shutdown_relabel = 0`` closes the open take without its final relabel:
    its cuts no relabel settled stand (confirmed at their frames) before ``closed``."""
    d, ep = start_daemon(relabel_interval=5.0, relabel_history=60.0, shutdown_relabel=0.0)
    got, done = [], threading.Event()
    th = _listen_until_closed(ep, "w", got, done)
    _send_take(ep, rec, "w", got, done, end=False)
    # every frame taken (counted as they are received)
    wait_until(lambda: d.n_frames >= rec.n_frames, "every frame taken", timeout=300)
    d.stop()
    assert done.wait(60), "no closed event"
    th.join(5)
    settles = _check_settled(got)
    assert got[-1].reason == "shutdown"
    stood = [
        e
        for e in settles.values()
        if e.type == "confirm" and e.emitted_at == rec.n_frames and e.settled == e.frame
    ]
    assert stood  # the last cuts had no relabel with settle_s of frames after them


def test_wire_fields_of_settled_cuts():
    """``settled`` and ``revision`` go on the wire only when set (older receivers see the
    events they knew), and come back as sent."""
    for ev in (
        protocol.Confirm("s", 10, 1.0, 1.6, 30, 10, 4),
        protocol.Withdraw("s", 11, 1.0, 31, False, 4),
        protocol.Cut("s", 12, 1.0, 0.0, 40, False, None, 4),
    ):
        back = protocol.decode(protocol.encode(ev, seq=3))
        assert back == ev and back.seq == 3
        assert protocol.to_json(ev)["revision"] == 4
    plain = protocol.Confirm("s", 10, 1.0, 1.6, 30)
    body = protocol.unpack_body(protocol.encode(plain)[1])
    assert "settled" not in body and "revision" not in body
    assert "revision" not in protocol.to_json(protocol.Withdraw("s", 1, 0.0, 2))
    bad = protocol.unpack_body(protocol.encode(protocol.Confirm("s", 1, 0.0, 1.0, 2, 1, 1))[1])
    bad["settled"] = -1
    with pytest.raises(protocol.WireError, match="settled"):
        protocol.from_body(bad)
