"""The versioned state contract (streamseg.state): every stateful component's stored fields
are those its STATE_VERSION promises, states round-trip, and a state of a newer release is
refused with a message naming the component and the version.

When this test fails because a class's stored fields changed: bump its ``STATE_VERSION``, add
the migration from the previous version to ``streamseg/state_migrations.py`` (a checkpoint of
the old version must restore), and record the new fields here.
"""

from __future__ import annotations

import copy
import importlib
import logging
import pkgutil

import msgpack
import numpy as np
import pytest

import streamseg
from streamseg.config.memory import LabelMemoryConfig
from streamseg.daemon.algorithms import Algorithms
from streamseg.daemon.checkpoint_store import CheckpointStore
from streamseg.daemon.pipeline import StreamPipeline
from streamseg.daemon.relabel_job import relabel
from streamseg.daemon.state_codec import dump, load, packable, stored
from streamseg.daemon.streams import StreamState
from streamseg.online.lof import StreamingLOFSegmenter
from streamseg.state import Stateful, StateVersionError
from streamseg.state_migrations import name_of
from tests.motion import lof_input

STORED = {
    "streamseg.daemon.pipeline:StreamPipeline": (
        3,
        {
            "_cap",
            "_feat",
            "_frames",
            "_spine",
            "_spine_n",
            "_width",
            "cut_frames",
            "filler",
            "final_bad",
            "final_reps",
            "fps",
            "gaps",
            "learned",
            "marker_fill",
            "next_frame",
            "notices",
            "offset",
            "previous",
            "rep_offset",
            "reps",
            "root",
            "segmenter",
            "settlement",
            "skeleton",
        },
    ),
    "streamseg.daemon.settle:Settlement": (
        1,
        {"due_at", "focus", "last", "open", "radius", "settle", "settled"},
    ),
    "streamseg.daemon.streams:StreamState": (
        1,
        {
            "client",
            "cuts",
            "dropped",
            "events_out",
            "fps",
            "frames_in",
            "gen",
            "labels",
            "last_seen",
            "lost",
            "next_relabel",
            "next_seq",
            "relabel_time",
            "reps",
            "revision",
            "segments",
            "seq_base",
            "stream",
            "t0",
        },
    ),
    "streamseg.io.gaps:GapFiller": (
        1,
        {
            "_gap_lost",
            "_gap_start",
            "_held",
            "_last",
            "_last_frame",
            "_lost",
            "_tail",
            "_touched",
            "filled_frames",
            "gaps",
            "max_frames",
            "n_joints",
            "next_frame",
            "released_lost",
            "watch",
        },
    ),
    "streamseg.offline.label_memory:ExemplarMemory": (
        1,
        {"born", "exemplars", "last_seen", "origin", "pending", "revisions", "stride", "weight"},
    ),
    "streamseg.online.lof:StreamingLOFSegmenter": (
        2,
        {
            "_centres",
            "_cols",
            "_cur",
            "_explicit_width",
            "_geo",
            "_p",
            "_pend",
            "_rb",
            "_rv",
            "_seqs",
            "_speeds",
            "_st",
            "_vecs",
            "config",
            "fps",
            "geometry",
            "n_features",
        },
    ),
    "streamseg.online.rep_bridge:PoseBridge": (
        1,
        {
            "_buf",
            "_lead",
            "_prev",
            "_since",
            "hold",
            "long_lost",
            "n_in",
            "n_joints",
            "n_out",
            "needed",
            "told",
        },
    ),
    "streamseg.online.rep_loops:PoseRing": (
        1,
        {"C", "SP", "Z", "_sos", "_state", "config", "cutoff", "dec", "k"},
    ),
    "streamseg.online.repetition:RepetitionCounter": (
        6,
        {
            "_Mm",
            "_bridge",
            "_cands",
            "_closed",
            "_cur",
            "_events",
            "_final",
            "_gap",
            "_idx",
            "_init",
            "_lag",
            "_lead",
            "_na",
            "_names",
            "_now",
            "_origin",
            "_pause",
            "_pending",
            "_pos",
            "_ring",
            "_scale",
            "_search",
            "_skip",
            "_st",
            "_tmax",
            "_unliked",
            "_up",
            "_upv",
            "_waits",
            "best_dissimilarity_",
            "config",
            "count_",
            "fps",
            "max_excursion_",
            "n_loops_",
            "n_seen_",
            "near_misses_",
            "sets_",
        },
    ),
    "streamseg.online.root_speed:RootSpeed": (
        1,
        {"_prev", "_ring", "_st", "fps", "jump", "lag", "limbs", "root", "up", "v_max"},
    ),
    "streamseg.online.speed_features:SpeedColumns": (
        2,
        {"_first", "_order", "_ref", "_ring", "_st", "d", "scale"},
    ),
}


@pytest.fixture(scope="module")
def full(rec):
    """A pipeline with every optional part (repetitions, label memory, gap filling, settling)
    after 30 s of 86_01 (a lost joint for 20 frames) and one relabel, and its stream state."""
    algorithms = Algorithms(
        repetitions=True,
        memory_config=LabelMemoryConfig(),
        gap_fill_s=0.25,
        settle_s=8.0,
        focus_s=20.0,
    )
    p = StreamPipeline(rec.skeleton, rec.fps, algorithms, history=30.0)
    pos = rec.positions.copy()
    pos[700:720, 4] = np.nan
    for a in range(0, 3600, 100):
        p.push(pos[a : a + 100], a)
    feats, frames, focused = p.relabel_snapshot(True)
    p.relabelled(
        relabel(algorithms, feats, frames, rec.fps, p.previous, tuple(p.cut_frames)),
        False,
        3600,
        focused,
    )
    return algorithms, p, pos, StreamState("x", 1, rec.fps, p, 0.0)


def _components(tree, out):
    if isinstance(tree, list):
        for x in tree:
            _components(x, out)
    elif isinstance(tree, dict):
        if "__obj__" in tree and "v" in tree:
            out[tree["__obj__"]] = (tree["v"], set(tree["s"]))
        for v in (tree["s"] if "__obj__" in tree else tree).values():
            _components(v, out)
    return out


def test_every_component_stores_what_its_version_promises(full):
    *_, st = full
    found = _components(dump({"stream": st, "pipeline": st.pipeline}), {})
    assert found == STORED


def test_every_stateful_class_is_in_the_contract():
    for m in pkgutil.walk_packages(streamseg.__path__, "streamseg."):
        if m.name.startswith(("streamseg.view", "streamseg.lsl")):
            continue  # optional extras: no stored state
        importlib.import_module(m.name)
    classes = {name_of(c) for c in _subclasses(Stateful)}
    assert classes == set(STORED)


def _subclasses(cls):
    for sub in cls.__subclasses__():
        yield sub
        yield from _subclasses(sub)


def test_a_restored_pipeline_goes_on_as_the_original(full, rec):
    algorithms, p, pos, _ = full
    p = copy.deepcopy(p)
    chunks: dict = {}
    body = msgpack.unpackb(
        msgpack.packb(packable(dump(p), chunks)), raw=False, strict_map_key=False
    )
    q = load(body, {d: stored(c) for d, c in chunks.items()})
    q.algorithms, q.plan = algorithms, algorithms.prepare(q.skeleton)
    a, b = [], []
    for f in range(3600, rec.n_frames, 100):
        a += p.push(pos[f : f + 100], f)[0]
        b += q.push(pos[f : f + 100], f)[0]
    a += p.finish()
    b += q.finish()
    assert a and a == b
    assert p.finish_reps() == q.finish_reps()


def test_to_state_and_from_state_of_the_detector(rec):
    x = lof_input(rec.positions, rec.skeleton, rec.fps)
    seg = StreamingLOFSegmenter(fps=rec.fps)
    seg.learn_many(x[:3000])
    state = copy.deepcopy(seg.to_state())
    assert state["version"] == StreamingLOFSegmenter.STATE_VERSION
    assert not set(state["fields"]) & set(StreamingLOFSegmenter._transient)
    back = StreamingLOFSegmenter.from_state(state)
    got = back.learn_many(x[3000:]) + back.finish()
    assert got and got == seg.learn_many(x[3000:]) + seg.finish()


def test_a_state_of_a_newer_release_is_refused():
    seg = StreamingLOFSegmenter(fps=120.0)
    state = seg.to_state()
    with pytest.raises(StateVersionError, match=r"StreamingLOFSegmenter state version 9"):
        StreamingLOFSegmenter.from_state({**state, "version": 9})
    with pytest.raises(StateVersionError, match="version 0"):
        StreamingLOFSegmenter.from_state({**state, "version": 0})


def test_the_daemon_refuses_a_newer_checkpoint_in_one_line(full, tmp_path, caplog):
    *_, st = full
    snap = dump({"stream": copy.deepcopy(st), "pipeline": copy.deepcopy(st.pipeline)})
    snap["__d__"][1][1]["v"] = 99  # the pipeline, as a later release would write it
    store = CheckpointStore(tmp_path)
    store.put([("x", 3600, snap)])
    store.wait()
    store.close()
    store = CheckpointStore(tmp_path)
    with caplog.at_level(logging.ERROR, logger="streamseg.daemon"):
        assert store.read_all() == []
    store.close()
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 1
    assert "checkpoints.sqlite" in lines[0] and "StreamPipeline state version 99" in lines[0]
