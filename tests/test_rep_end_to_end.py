"""Repetition segmentation end to end on real HDM05 repetitions (issue 6).

The sequence is four real single-repetition squat clips of actor bd concatenated (a fair way
to get known repetition boundaries: the joins, see data/README.md).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from streamseg.cli import main
from streamseg.evaluation.metrics import repetition_accuracy
from streamseg.io import write_npz
from streamseg.offline.repetition import RepetitionSegmenter
from streamseg.online.repetition import RepetitionCounter, RepEvent


@pytest.fixture(scope="module")
def squats(bd_squats):
    return bd_squats


@pytest.fixture(scope="module")
def fitted(squats):
    rec, _ = squats
    return RepetitionSegmenter().fit(rec)


def test_four_real_squats_are_found(squats, fitted):
    rec, truth = squats
    assert fitted.count_ == 4
    assert repetition_accuracy(fitted.repetitions_, truth) > 0.9
    # every true join has a found boundary within a quarter of a repetition
    found = np.array([s for s, _ in fitted.repetitions_[1:]])
    for _, end in truth[:-1]:
        assert np.min(np.abs(found - end)) < 0.25 * np.mean([b - a for a, b in truth])
    # squats move the legs: the selected parameters are leg bones
    names = [fitted.param_names_[i] for i in fitted.analysis_.selected]
    assert all(("femur" in n or "tibia" in n) for n in names[:3]), names
    assert fitted.joint_angles_.shape == (rec.n_frames, 20)


def test_cli_segment_json_and_plot(squats, tmp_path, capsys):
    rec, truth = squats
    path = tmp_path / "squats.npz"
    write_npz(path, rec)
    png = tmp_path / "reps.png"
    assert main(["segment", str(path), "--method", "rep", "--json", "--plot", str(png)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["method"] == "rep" and out["n_frames"] == rec.n_frames and out["fps"] == 120.0
    assert out["count"] == len(out["repetitions"]) == 4
    assert all(0 <= r["start"] < r["end"] <= rec.n_frames for r in out["repetitions"])
    assert 0.3 < out["primary_frequency_hz"] < 1.5
    assert out["repetitive"] is True
    assert png.stat().st_size > 10_000


def test_live_counter_counts_the_squats_with_bounded_delay(squats):
    rec, truth = squats
    counter = RepetitionCounter(None, rec.fps, rec.skeleton)
    events = []
    for i in range(0, rec.n_frames, 37):  # uneven chunks, as frames arrive
        events += counter.learn_many(rec.positions[i:i + 37])
    assert all(isinstance(e, RepEvent) for e in events)
    assert [e.count for e in events] == list(range(1, len(events) + 1))
    assert len(events) >= 3  # the last repetition may end too close to the stream's end
    mean_len = np.mean([b - a for a, b in truth])
    first = events[0].emitted_at  # the first events may catch up on the buffer
    for e in events:
        assert e.emitted_at >= e.end
        if e.emitted_at > first:  # then: the documented bound, 0.85 period + one hop
            assert e.emitted_at - e.end <= 0.85 * mean_len + counter._hop
        # each event matches a true repetition's end within a quarter repetition
        assert min(abs(e.end - b) for _, b in truth) < 0.25 * mean_len
    with pytest.raises(Exception, match="shape"):
        counter.learn_many(np.zeros((3, 2, 3)))


def test_live_final_count_equals_the_offline_count(squats, fitted):
    rec, truth = squats
    counter = RepetitionCounter(None, rec.fps, rec.skeleton)
    events = []
    for i in range(0, rec.n_frames, 30):
        events += counter.learn_many(rec.positions[i:i + 30])
    before = len(events)
    events += counter.finish()
    assert events[-1].count == fitted.count_ == len(truth)
    assert before < len(events)  # the last squat only finish() can report
    mean_len = np.mean([b - a for a, b in truth])
    for e in events[:3]:  # the first repetitions of the set: ends within 0.25 repetition
        assert min(abs(e.end - b) for _, b in truth) < 0.25 * mean_len


def test_live_events_do_not_depend_on_chunking(squats):
    rec, _ = squats
    pos = rec.positions[:400]
    whole = RepetitionCounter(None, rec.fps, rec.skeleton).learn_many(pos)
    counter = RepetitionCounter(None, rec.fps, rec.skeleton.names)
    pieces = []
    for i in range(0, 400, 23):
        pieces += counter.learn_many(pos[i:i + 23])
    assert pieces == whole and len(whole) >= 1
    one = RepetitionCounter(None, rec.fps, rec.skeleton)
    singles = [e for f in pos for e in one.learn_one(f)]
    assert singles == whole
