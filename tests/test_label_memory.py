"""The exemplar memory that keeps ids beyond the relabel history (offline.label_memory)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from streamseg.config.memory import LabelMemoryConfig
from streamseg.daemon.algorithms import Algorithms
from streamseg.daemon.relabel_job import relabel
from streamseg.exceptions import ParameterError
from streamseg.offline.label_memory import new_memory
from tests.motion import FPS, cyclic_blocks, revisions


def _blocks(levels, seconds=4.0, seed=0, d=6):
    return cyclic_blocks(levels, seconds, seed, d)


def _stream_ids(X, memory, history=6.0, interval=1.0):
    """Revisions as the daemon runs them; per-frame ids of the newest revision."""
    algos = Algorithms(memory_config=LabelMemoryConfig() if memory else None)
    return revisions(algos, X, FPS, history, interval)


def _block_id(lab, i, seconds=4.0):
    n = int(seconds * FPS)
    part = lab[i * n : (i + 1) * n]
    return np.bincount(part).argmax()


def test_an_action_back_after_the_history_keeps_its_id():
    # A, B, C, A: the second A starts 8 s after the first ended, the history is 6 s
    X = _blocks([0.5, 1.5, 2.5, 0.5])
    without, _ = _stream_ids(X, memory=False)
    assert _block_id(without, 3) != _block_id(without, 0)  # the hole the memory fills
    lab, last = _stream_ids(X, memory=True)
    ids = [_block_id(lab, i) for i in range(4)]
    assert ids[3] == ids[0] and len(set(ids[:3])) == 3
    assert last.memory is not None and ids[0] in last.memory.exemplars


def test_a_new_action_after_the_history_gets_a_new_id():
    X = _blocks([0.5, 1.5, 2.5, 3.5])
    lab, last = _stream_ids(X, memory=True)
    ids = [_block_id(lab, i) for i in range(4)]
    assert len(set(ids)) == 4
    assert ids[3] >= max(ids[:3])  # a fresh id, never one the stream used
    assert last.next_id > ids[3]


def test_memory_is_bounded_in_ids_and_bytes():
    cfg = LabelMemoryConfig(max_ids=3, per_id=2, exemplar_s=1.0, rate_hz=30.0)
    mem = new_memory(cfg, FPS)
    rng = np.random.default_rng(0)
    d = 17
    for rev in range(12):  # each revision holds two new ids of 3 s
        start = rev * 720
        frames = np.arange(start, start + 720)
        feats = rng.random((720, d))
        segs = [(start, start + 360, 2 * rev), (start + 360, start + 720, 2 * rev + 1)]
        mem = mem.updated(segs, feats, frames, cfg, FPS)
        assert len(mem.exemplars) <= cfg.max_ids
        assert mem.nbytes <= cfg.max_bytes(d)
    assert {22, 23} <= set(mem.exemplars)  # the ids this revision holds are kept
    for ex in mem.exemplars.values():
        assert len(ex) <= cfg.per_id
        assert all(a.dtype == np.float32 and a.shape[0] <= 30 for a in ex)
    assert cfg.max_bytes(17) == 3 * 2 * 30 * 17 * 4


def _revisions(X, memory, history=6.0, interval=1.0, config=None):
    """Every revision's Relabelled, as the daemon runs them."""
    cfg = config or (LabelMemoryConfig() if memory else None)
    algos = Algorithms(memory_config=cfg)
    n = X.shape[0]
    step, span = int(interval * FPS), int(history * FPS)
    out, previous = [], None
    for t in list(range(step, n, step)) + [n]:
        s = max(0, t - span)
        res = relabel(algos, X[s:t], np.arange(s, t), FPS, previous)
        previous = res.window
        out.append(res)
    return out


def test_the_recall_never_changes_a_windows_segmentation():
    # post hoc: same boundaries in every revision, ids renamed one to one
    X = _blocks([0.5, 1.5, 2.5, 0.5, 3.5, 1.5])
    without = _revisions(X, memory=False)
    with_memory = _revisions(X, memory=True)
    renamed = 0
    for a, b in zip(without, with_memory, strict=True):
        assert [s[:2] for s in a.segments] == [s[:2] for s in b.segments]
        pairs = {(s[2], t[2]) for s, t in zip(a.segments, b.segments, strict=True)}
        assert len(pairs) == len({p for p, _ in pairs}) == len({q for _, q in pairs})
        renamed += any(p != q for p, q in pairs)
    assert renamed  # the memory did rename something


def test_memory_stays_bounded_over_many_actions():
    cfg = LabelMemoryConfig(max_ids=3)
    X = _blocks([0.5, 1.5, 2.5, 3.5, 4.5, 5.5, 6.5, 7.5], seconds=3.0)
    for res in _revisions(X, memory=True, config=cfg):
        mem = res.window.memory
        ids = {s[2] for s in res.segments}
        assert len(mem.exemplars) <= cfg.max_ids and mem.nbytes <= cfg.max_bytes(X.shape[1])
        assert len(mem.born) <= cfg.max_ids + len(ids) and len(mem.pending) <= len(ids)
    assert res.window.next_id >= 8  # eight actions, eight ids


@pytest.mark.parametrize(
    "field,value",
    [
        ("max_ids", 0),
        ("per_id", 1.5),
        ("exemplar_s", 0),
        ("rate_hz", -1),
        ("recall_ratio", float("nan")),
        ("recall_margin", -0.1),
        ("recall_confirm", 3),
        ("recall_pieces", 1),
        ("recall_within", 0),
    ],
)
def test_bad_memory_settings_are_refused(field, value):
    with pytest.raises(ParameterError, match=field):
        LabelMemoryConfig(**{field: value})


def _replay_in_steps(rec, endpoint, sub, stream, step):
    """Send ``rec`` ``step`` frames at a time, each time waiting for the revision that covers
    them (a handshake: the daemon relabels every ``step`` frames), then end the stream.
    Returns every ``segments`` event of the stream."""
    import zmq

    from streamseg import protocol
    from streamseg.client import listen
    from streamseg.commands.replay import announce_of

    push = zmq.Context.instance().socket(zmq.PUSH)
    push.setsockopt(zmq.LINGER, 5000)
    push.connect(endpoint)
    events = []
    try:
        push.send_multipart(protocol.encode(announce_of(rec, stream)))
        pos = rec.positions
        for a in range(0, rec.n_frames, step):
            b = min(a + step, rec.n_frames)
            for c in range(a, b, 60):
                push.send_multipart(
                    protocol.encode(protocol.Frames(stream, c, 0.0, pos[c : min(c + 60, b)]))
                )
            if b - a < step:
                break  # the last revision comes with the end of the stream
            for e in listen(sub, stream=stream, timeout=120):
                if e.type == "segments":
                    events.append(e)
                    if e.end >= b:
                        break
        push.send_multipart(protocol.encode(protocol.End(stream)))
        events += [
            e
            for e in listen(sub, stream=stream, until_end=True, timeout=120)
            if e.type == "segments"
        ]
    finally:
        push.close()
    return events


@pytest.mark.daemon
@pytest.mark.slow
@pytest.mark.parametrize("memory", [True, False])
def test_daemon_keeps_the_id_of_an_action_back_after_the_history(data_dir, start_daemon, memory):
    """Real daemon over loopback, 15 s history: CMU 14_14's jumping jacks, jog, squats and
    knee raises (19 s), then the jumping jacks of another take (14_20), then punches (86_01,
    an action not seen before; abrupt joins). The returning jumping jacks start 15.4 s after
    the first ones ended, beyond the history: with the memory they get the first ones' id;
    without it, a new one. The punches get a new id either way."""
    from streamseg.client import listen, subscriber
    from streamseg.evaluation.datasets import _cmu_take, _slice, concatenate

    a, _ = _cmu_take(data_dir, "14_14")
    b, _ = _cmu_take(data_dir, "14_20")
    c, _ = _cmu_take(data_dir, "86_01")
    cut = 2280  # 14_14 up to the end of its knee raises; 14_20 frames 0-431 are jumping jacks
    back_end = cut + 432
    rec = concatenate([_slice(a, 0, cut), _slice(b, 0, 432), _slice(c, 1980, 2500)])[0]
    d, ep = start_daemon(
        relabel_interval=2.5,
        relabel_history=15.0,
        relabel_share=1.0,
        heartbeat=0.05,
        label_memory=memory,
    )
    sub = subscriber(ep["publish"])
    try:
        next(e for e in listen(sub, timeout=30) if e.type == "stats")  # subscribed
        events = _replay_in_steps(rec, ep["ingest"], sub, "ret", int(2.5 * rec.fps))
    finally:
        sub.close()
    assert events and events[-1].final
    live = np.full(rec.n_frames, -1)
    for e in events:
        for s, t, lab in e.segments:
            live[s:t] = lab
    first = np.bincount(live[:456]).argmax()  # 14_14 jumping jacks: frames 0-455
    back = live[cut:back_end]
    assert events[-1].start > 456  # the last revisions no longer hold the first ones
    if memory:
        assert np.mean(back == first) >= 0.9
    else:
        assert np.mean(back == first) == 0.0
    punch = np.bincount(live[back_end:]).argmax()
    assert punch not in set(live[:back_end].tolist())  # a new action, a new id


def test_a_take_within_the_history_relabels_as_without_the_memory():
    # no split here, so the merge has nothing to join (tests/test_merge_present.py splits)
    X = _blocks([0.5, 1.5, 2.5, 0.5], seconds=2.0)  # 8 s, history 10 s
    with_memory, last = _stream_ids(X, memory=True, history=10.0, interval=2.0)
    without, _ = _stream_ids(X, memory=False, history=10.0, interval=2.0)
    assert np.array_equal(with_memory, without)
    assert last.memory is not None and last.memory.exemplars  # remembered all the same


def test_memory_survives_a_checkpoint(tmp_path):
    from streamseg.daemon.checkpoint_store import CheckpointStore
    from streamseg.daemon.state_codec import dump
    from streamseg.offline.relabel import WindowSegmentation

    cfg = LabelMemoryConfig()
    rng = np.random.default_rng(1)
    feats = rng.random((1200, 17)).astype(np.float32)
    mem = new_memory(cfg, FPS, 0).updated(
        [(0, 10, 0), (10, 600, 1), (600, 1190, 2), (1190, 1200, 0)],
        feats,
        np.arange(1200),
        cfg,
        FPS,
    )
    mem = replace(mem, born={1: 0, 2: -1}, pending={2: 1}, revisions=3)  # recall's state
    w = WindowSegmentation(0, 1200, [(0, 600, 1), (600, 1200, 2)], 2, 3, memory=mem)
    store = CheckpointStore(tmp_path)  # the real SQLite file, chunks and all
    store.put([("s", 1200, dump(w))])
    assert store.wait()
    store.close()
    ((_, back),) = CheckpointStore(tmp_path).read_all()
    assert back.segments == w.segments and back.next_id == 3
    assert sorted(back.memory.exemplars) == sorted(mem.exemplars) == [1, 2]
    for i in mem.exemplars:
        for a, b in zip(mem.exemplars[i], back.memory.exemplars[i], strict=True):
            assert np.array_equal(a, b)
    assert back.memory.last_seen == mem.last_seen and back.memory.stride == mem.stride
    assert (back.memory.born, back.memory.pending, back.memory.revisions) == (
        {1: 0, 2: -1},
        {2: 1},
        3,
    )


@pytest.mark.slow
def test_return_streams_bring_actions_back_after_the_history(data_dir):
    from streamseg.evaluation.datasets import return_streams

    streams = return_streams(data_dir)
    assert set(streams) == {
        "ret_14_86_14",
        "ret_86_14_14_86",
        "ret_hdm_bd",
        "ret_hdm_bk",
        "ret_hdm_dg",
    }
    for name, (rec, names) in streams.items():
        assert names.shape == (rec.n_frames,) and (names != "").all(), name
        back = []
        for action in np.unique(names):
            idx = np.flatnonzero(names == action)
            if (np.diff(idx) > 60 * rec.fps).any():
                back.append(action)
        assert back, f"{name}: no action returns after 60 s"
        if name.startswith("ret_hdm"):
            assert set(back) == {"squat1Reps", "hopBothLegs1hops"}, name


def test_a_memory_from_before_the_recall_state_still_relabels():
    # a checkpoint of the previous memory shape has no born / pending / revisions
    X = _blocks([0.5, 1.5, 2.5, 0.5])
    revs = _revisions(X, memory=True)
    old = revs[8].window.memory
    for name in ("born", "pending", "revisions"):
        del old.__dict__[name]
    t = revs[9].end
    res = relabel(
        Algorithms(memory_config=LabelMemoryConfig()),
        X[t - 720 : t + 120],
        np.arange(t - 720, t + 120),
        FPS,
        revs[8].window,
    )
    assert res.segments and res.window.memory.revisions == 1
