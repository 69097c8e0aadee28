"""The two-stage cut decision (``LOFConfig.early_delay_s``): pending cuts emitted early,
confirmed or withdrawn by the unchanged final stage; the final cuts are the one-stage cuts,
online and offline, after a checkpoint restore, and through a real daemon to its listeners."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from streamseg import protocol
from streamseg.cli import main
from streamseg.config import LOFConfig
from streamseg.daemon.algorithms import Algorithms
from streamseg.daemon.cut_events import cut_kind
from streamseg.daemon.pipeline import StreamPipeline
from streamseg.daemon.streams import StreamState
from streamseg.evaluation.datasets import CMU02_SEQUENCES, cmu02_sequence
from streamseg.exceptions import ParameterError
from streamseg.offline import LOFSegmenter
from streamseg.offline.lof import lof_features
from streamseg.online import (
    ConfirmEvent,
    CutEvent,
    StreamingLOFSegmenter,
    WithdrawEvent,
    final_cuts,
)
from tests.cli_words import STREAMSEG, listen_to
from tests.naive import naive_settle
from tests.test_checkpoint_store import through_sqlite

FPS = 120.0
#: on 86_01 this early stage's cut at frame 1128 moves (withdrawn, a final cut follows)
TWO = LOFConfig(delay_s=1.5, early_delay_s=1.2)


def _feed(cfg, angles, packet=120):
    det = StreamingLOFSegmenter(cfg, FPS)
    live = []
    for i in range(0, len(angles), packet):
        live += det.learn_many(angles[i : i + packet])
    return det, live, det.finish()


@pytest.fixture(scope="module")
def angles86(rec):
    return lof_features(rec)


@pytest.fixture(scope="module")
def angles_cmu02(data_dir):
    name = "02_wash_sword_walk_punch"
    r, _ = cmu02_sequence(data_dir, CMU02_SEQUENCES[name])
    return lof_features(r)


def _check_settled(events):
    """Every confirm/withdraw settles one earlier unsettled pending cut; a moved withdraw is
    followed by a final cut at another frame; nothing is pending at the end."""
    open_ = []
    for i, ev in enumerate(events):
        if isinstance(ev, CutEvent) and ev.pending:
            open_.append(ev.frame)
        elif isinstance(ev, (ConfirmEvent, WithdrawEvent)):
            assert ev.frame in open_, (i, ev)
            open_.remove(ev.frame)
            if isinstance(ev, WithdrawEvent) and ev.moved:
                nxt = events[i + 1]
                assert isinstance(nxt, CutEvent) and not nxt.pending and nxt.frame != ev.frame
    assert open_ == []


@pytest.mark.parametrize("early", [0.8, 1.0, 1.2])
def test_final_cuts_are_the_one_stage_cuts_live_and_offline(angles86, angles_cmu02, early):
    for a in (angles86, angles_cmu02):
        one = LOFConfig(delay_s=1.5)
        two = LOFConfig(delay_s=1.5, early_delay_s=early)
        _, live1, end1 = _feed(one, a)
        _, live2, end2 = _feed(two, a, packet=37)
        # event for event: frame, score and the frame of the final decision
        assert final_cuts(live2 + end2) == live1 + end1
        _check_settled(live2 + end2)
        off1 = LOFSegmenter(one, FPS).fit(a)
        off2 = LOFSegmenter(two, FPS).fit(a)
        np.testing.assert_array_equal(off2.cuts_, off1.cuts_)
        np.testing.assert_array_equal(off2.decided_at_, off1.decided_at_)
        assert list(off2.cuts_) == [c.frame for c in live1 + end1]


def test_settling_matches_the_naive_twin(angles86, angles_cmu02):
    """The kernel's live confirm / withdraw / moved events equal a naive replay of the rule
    from the pending cuts and the one-stage decisions (the end of the stream: see
    :func:`_check_settled`)."""
    kinds = set()
    for a, early in ((angles86, 1.2), (angles_cmu02, 0.8), (angles_cmu02, 1.0)):
        cfg = LOFConfig(delay_s=1.5, early_delay_s=early)
        _, live, _ = _feed(cfg, a)
        _, one_live, _ = _feed(LOFConfig(delay_s=1.5), a)
        pending = [
            (e.frame, e.score, e.emitted_at) for e in live if isinstance(e, CutEvent) and e.pending
        ]
        want = naive_settle(
            pending, [(c.frame, c.score, c.emitted_at) for c in one_live], cfg.frames(FPS), len(a)
        )
        got = [(cut_kind(e), e.frame, e.emitted_at) for e in live]
        assert got == want
        kinds |= {k for k, _, _ in got}
    # every kind occurs here: pending and final cuts, confirms, both withdraws
    assert kinds == {"cut", "pending", "confirm", "withdraw", "moved"}


def test_early_delay_off_is_one_stage_and_bad_values_are_refused(angles86):
    base = _feed(LOFConfig(), angles86)
    for off in (None, 0, 0.0):
        assert _feed(LOFConfig(early_delay_s=off), angles86)[1:] == base[1:]
    for bad in (-0.5, 1.5, 2.0, True, "1"):
        with pytest.raises(ParameterError, match="early_delay_s"):
            LOFConfig(early_delay_s=bad)
    # 1.4 s is 7 windows of 0.2 s at 120 Hz but rounds to the 1.5 s delay's window at 10 Hz
    with pytest.raises(ParameterError, match="early_delay_s"):
        StreamingLOFSegmenter(LOFConfig(step_s=0.5, early_delay_s=1.4), fps=10.0)


def test_a_restored_stream_settles_its_pending_cut_as_the_original(tmp_path, rec, warm_kernels):
    """Checkpointed with a pending cut: the restored stream withdraws it (and emits the
    moved cut) exactly as the uninterrupted stream does."""
    _, live, _ = _feed(TWO, lof_features(rec))
    first = next(e for e in live if isinstance(e, CutEvent) and e.pending)
    settle = next(e for e in live if not isinstance(e, CutEvent) and e.frame == first.frame)
    algorithms = Algorithms(TWO)
    p = StreamPipeline(rec.skeleton, rec.fps, algorithms, 60.0)
    n = first.emitted_at + 1
    cuts, _, _ = p.push(rec.positions[:n], 0)
    assert (first.frame, "pending") in [(c[0], c[3]) for c in cuts]
    assert p.segmenter._st[13] == 1  # one pending cut in the state (ST_PENDING)
    st = StreamState("s", 1, rec.fps, p, 0.0)
    st.next_seq = n
    back = through_sqlite(tmp_path, st, algorithms)[1]["pipeline"]
    rest = rec.positions[n:]
    want = p.push(rest, n)[0] + p.finish()
    got = back.push(rest, n)[0] + back.finish()
    assert got == want
    assert (first.frame, "moved" if settle.moved else "withdraw") in [(c[0], c[3]) for c in got]
    # the relabel's cut list holds the final cuts only
    assert first.frame not in back.cut_frames
    assert list(back.cut_frames) == list(p.cut_frames)


def test_wire_fields_of_pending_cuts_confirm_and_withdraw():
    plain = protocol.Cut("s", 10, 1.0, 1.5, 20, True)
    body = protocol.unpack_body(protocol.encode(plain)[1])
    assert "pending" not in body and protocol.decode(protocol.encode(plain)) == plain
    assert "pending" not in protocol.to_json(plain)
    for ev in (
        protocol.Cut("s", 10, 1.0, 1.5, 20, True, True),
        protocol.Confirm("s", 10, 1.0, 1.6, 30),
        protocol.Withdraw("s", 10, 1.0, 30, True),
        protocol.Withdraw("s", 11, 1.0, 31, False),
    ):
        parts = protocol.encode(ev, seq=7)
        assert parts[0] == f"{ev.type}/s/".encode()
        back = protocol.decode(parts)
        assert back == ev and back.seq == 7
    assert b"confirm/s/" in protocol.subscriptions(stream="s")
    assert b"withdraw/s/" in protocol.subscriptions(stream="s")
    bad = protocol.unpack_body(protocol.encode(protocol.Cut("s", 1, 0.0, 1.0, 2, True))[1])
    bad["pending"] = "yes"
    with pytest.raises(protocol.WireError, match="pending"):
        protocol.from_body(bad)


@pytest.mark.daemon
def test_daemon_withdraws_a_pending_cut_and_the_listeners_drop_it(
    start_daemon, data_dir, rec, tmp_path
):
    """A real daemon over loopback with the two-stage decision: the pending cut at 86_01's
    frame 1128 is withdrawn; `streamseg listen` and the minimal listener end with the final
    cuts (the offline cuts), without it; the event log holds the withdraw."""
    d, ep = start_daemon(Algorithms(TWO), state_dir=str(tmp_path / "state"))
    a = lof_features(rec)
    _, live, end = _feed(TWO, a)
    events = live + end
    withdrawn = [e.frame for e in events if isinstance(e, WithdrawEvent)]
    assert 1128 in withdrawn
    final = [int(f) for f in LOFSegmenter(TWO, FPS).fit(a).cuts_]
    assert 1128 not in final
    script = Path(__file__).resolve().parents[1] / "clients" / "python" / "listener.py"
    mini = subprocess.Popen(
        [sys.executable, str(script), ep["publish"], "w", "--control", ep["control"]],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert mini.stdout.readline().startswith("listening on")
    cli = subprocess.Popen(
        [
            *STREAMSEG,
            *listen_to(ep),
            "--stream",
            "w",
            "--jsonl",
            "--until-end",
            "--timeout",
            "60",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert json.loads(cli.stdout.readline())["type"] == "state"  # subscribed, handshaken
    assert (
        main(
            [
                "replay",
                str(data_dir / "cmu86" / "86_01.amc.gz"),
                "--skeleton",
                str(data_dir / "cmu86" / "86.asf"),
                "--to",
                ep["ingest"],
                "--speed",
                "0",
                "--batch",
                "60",
                "--stream",
                "w",
            ]
        )
        == 0
    )
    out, _ = mini.communicate(timeout=60)
    lines = out.splitlines()
    assert any("cut at frame 1128 " in x and "pending" in x for x in lines)
    assert any(x.startswith("w: withdraw of the cut at frame 1128 ") for x in lines)
    assert lines[-2] == f"w: final cuts {final}" and lines[-1] == "w: closed (end)"
    out, err = cli.communicate(timeout=60)
    rows = [json.loads(x) for x in out.splitlines()]
    kinds = [r["type"] for r in rows]
    assert "withdraw" in kinds and "confirm" in kinds
    summary = [r for r in rows if r["type"] == "cuts"]
    assert summary == [
        {"type": "cuts", "stream": "w", "frames": final, "withdrawn": len(withdrawn)}
    ]
    # numbered like every event, in the event log
    seqs = [r["seq"] for r in rows if "seq" in r]
    assert seqs == list(range(1, len(seqs) + 1))
    from streamseg.client import fetch_since, request

    # the late joiner's snapshot: withdrawn cuts gone, confirmed ones final (no relabel ran)
    state = request(ep["control"], "state", stream="w")
    assert [c["frame"] for c in state["cuts"]] == final
    assert not any(c.get("pending") for c in state["cuts"])

    logged = fetch_since(ep["control"], "w", 0)
    while logged[-1].seq < seqs[-1]:  # the log is written a moment after publication
        logged = fetch_since(ep["control"], "w", 0)
    assert [e.type for e in logged] == [r["type"] for r in rows if "seq" in r]
    assert [e.frame for e in logged if e.type == "withdraw"] == withdrawn


def test_a_detector_saved_before_the_two_stage_decision_restores_as_one_stage(angles86):
    """A checkpoint written before ``early_delay_s`` existed has no pending-cut array, a
    7-slot parameter array and a 10-slot state: it goes on as the one-stage detector."""
    import msgpack

    from streamseg.daemon.state_codec import dump, load, packable

    a = angles86
    live = StreamingLOFSegmenter(LOFConfig(), FPS)
    live.learn_many(a[:3000])
    saved = dump(live)
    saved["v"] = 1  # the detector's state version then
    del saved["s"]["_pend"]
    del saved["s"]["config"]["s"]["early_delay_s"]  # the config had no such field then
    for name, size in (("_p", 7), ("_st", 10)):
        arr = saved["s"][name]["__nd__"]
        arr[1], arr[2] = [size], arr[2][:size].copy()
    chunks: dict = {}
    body = msgpack.unpackb(msgpack.packb(packable(saved, chunks)), strict_map_key=False)
    old = load(body, {k: bytes(v) for k, v in chunks.items()})
    assert old._p.size == 7 and old._st.size == 10 and old._pend.shape == (0, 2)
    assert old.config == LOFConfig()  # the new field takes its default
    got = old.learn_many(a[3000:]) + old.finish()
    assert got and got == live.learn_many(a[3000:]) + live.finish()


def test_the_view_drops_a_withdrawn_cut_and_redraws():
    from streamseg.view.model import Hub

    hub = Hub(clock=lambda: 0.0)
    for ev in (
        protocol.Cut("v", 100, 1.0, 1.4, 300, True, True),
        protocol.Cut("v", 900, 8.0, 1.3, 1100, True, True),
        protocol.Confirm("v", 100, 1.0, 1.5, 400),
        protocol.Withdraw("v", 900, 8.0, 1200, True),
        protocol.Cut("v", 930, 8.2, 1.3, 1200, True),
    ):
        hub.apply(ev)
    tl = hub.streams["v"].timeline()
    assert [c["frame"] for c in tl["cuts"]] == [100, 930]
    assert tl["cut_version"] == 1  # a page that had frame 900 redraws the stream whole
