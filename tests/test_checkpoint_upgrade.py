"""A daemon upgraded in place restores the streams the previous release checkpointed.

``tests/fixtures/checkpoints_3e14a8b`` is the state directory a daemon of commit 3e14a8b
left with stream ``k`` open at frame 2,000 of CMU 86_01 (made by
``tests/fixtures/make_checkpoints.py`` with that commit's code). Today's daemon, started on a
copy of it, resumes ``k`` at frame 2,000 and, given the rest of the take, publishes the cuts
an uninterrupted run decides from frame 2,000 on.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import zmq

from streamseg import protocol as P
from streamseg.client import fetch_since, request
from streamseg.online.lof import StreamingLOFSegmenter
from tests.motion import lof_input
from tests.test_daemon_restart import config, serve, wait_ping
from tests.waiting import wait_until

FIXTURE = Path(__file__).parent / "fixtures" / "checkpoints_3e14a8b"
RESUMED_AT = 2000


def test_checkpoints_of_the_previous_release_restore(tmp_path, rec):
    ep, state, toml = config(tmp_path, relabel_interval=2.0, relabel_history=8.0, heartbeat=0)
    shutil.copytree(FIXTURE, state)
    proc = serve(toml)
    try:
        wait_ping(ep, proc)
        streams = {s["stream"]: s for s in request(ep["control"], "streams")["streams"]}
        assert streams["k"]["frame"] == RESUMED_AT
        push = zmq.Context.instance().socket(zmq.PUSH)
        push.connect(ep["ingest"])
        for a in range(RESUMED_AT, rec.n_frames, 20):
            push.send_multipart(P.encode(P.Frames("k", a, 0.0, rec.positions[a : a + 20])))
        push.send_multipart(P.encode(P.End("k")))
        events = wait_until(
            lambda: (
                (evs := fetch_since(ep["control"], "k", 0)) and evs[-1].type == "closed" and evs
            ),
            "the resumed take closed",
            timeout=120,
        )
        push.close(linger=0)
    finally:
        proc.terminate()
        proc.wait(60)
    seg = StreamingLOFSegmenter(fps=rec.fps)
    ref = seg.learn_many(lof_input(rec.positions, rec.skeleton, rec.fps)) + seg.finish()
    resumed = [e for e in events if e.type == "cut" and e.emitted_at >= RESUMED_AT]
    assert [c.frame for c in resumed] == [c.frame for c in ref if c.emitted_at >= RESUMED_AT]
    assert not [e for e in events if e.type == "error"]
    final = [e for e in events if e.type == "segments" and e.final]
    assert final and final[-1].end == rec.n_frames


def test_a_checkpoint_of_an_unknown_format_is_refused_with_one_line(tmp_path):
    """A checkpoint this release cannot read (a later release's) is not restored: one log line
    names the stream, the file and the format; the daemon starts without it."""
    import sqlite3

    ep, state, toml = config(tmp_path, heartbeat=0)
    shutil.copytree(FIXTURE, state)
    con = sqlite3.connect(state / "checkpoints.sqlite")
    con.execute("UPDATE checkpoints SET format = 99")
    con.commit()
    con.close()
    proc = serve(toml)
    try:
        wait_ping(ep, proc)
        assert request(ep["control"], "streams")["streams"] == []
    finally:
        proc.terminate()
        proc.wait(60)
    lines = [x for x in proc.stderr.read().splitlines() if "format 99" in x]
    assert len(lines) == 1 and "checkpoint of k" in lines[0]
    assert str(state / "checkpoints.sqlite") in lines[0] and "reads formats 5, 6, 7" in lines[0]
