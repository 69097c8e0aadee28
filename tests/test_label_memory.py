"""The exemplar memory that keeps ids beyond the relabel history (streamseg.offline.label_memory)."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg.config.memory import LabelMemoryConfig
from streamseg.daemon.pipeline import Algorithms, relabel
from streamseg.exceptions import ParameterError
from streamseg.offline.label_memory import new_memory

FPS = 120.0


def _blocks(levels, seconds=4.0, seed=0, d=6):
    """Blocks of a noisy cyclic motion around each level (radians), one block per level."""
    rng = np.random.default_rng(seed)
    n = int(seconds * FPS)
    t = np.arange(n)[:, None]
    return np.concatenate([lv + 0.3 * np.sin(2 * np.pi * t / 60 + np.arange(d))
                           + rng.normal(0, 0.02, (n, d)) for lv in levels])


def _stream_ids(X, memory, history=6.0, interval=1.0):
    """Revisions as the daemon runs them; per-frame ids of the newest revision."""
    algos = Algorithms(memory_config=LabelMemoryConfig() if memory else None)
    n = X.shape[0]
    step, span = int(interval * FPS), int(history * FPS)
    lab = np.full(n, -1)
    previous = None
    for t in list(range(step, n, step)) + [n]:
        s = max(0, t - span)
        res = relabel(algos, X[s:t], np.arange(s, t), FPS, previous)
        previous = res.window
        for a, b, c in res.segments:
            lab[a:b] = c
    return lab, previous


def _block_id(lab, i, seconds=4.0):
    n = int(seconds * FPS)
    part = lab[i * n:(i + 1) * n]
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


def test_exemplars_of_ids_still_in_the_window_are_not_appended():
    cfg = LabelMemoryConfig()
    mem = new_memory(cfg, FPS).updated([(0, 600, 0), (600, 1200, 1)], np.ones((1200, 4)),
                                       np.arange(1200), cfg, FPS)
    assert mem.absent([(0, 600, 0), (600, 1200, 1)], 700) == [0]
    assert mem.absent([(0, 600, 0), (600, 1200, 1)], 500) == []
    pieces = mem.pieces([0])
    assert len(pieces) == cfg.per_id and all(p.shape[1] == 4 for _, p in pieces)


@pytest.mark.parametrize("field,value", [("max_ids", 0), ("per_id", 1.5), ("exemplar_s", 0),
                                         ("rate_hz", -1)])
def test_bad_memory_settings_are_refused(field, value):
    with pytest.raises(ParameterError, match=field):
        LabelMemoryConfig(**{field: value})
