"""A revision's alternation of two labels (one action's halves) is published as one action
(streamseg.daemon.alternation)."""

from __future__ import annotations

from streamseg.daemon.algorithms import Algorithms
from streamseg.daemon.alternation import merge_alternations
from streamseg.daemon.options import skeleton_from
from streamseg.daemon.pipeline import StreamPipeline
from streamseg.daemon.relabel_job import relabel


def _changes(segs) -> list:
    return [b[0] for a, b in zip(segs[:-1], segs[1:]) if a[2] != b[2]]


def test_two_labels_alternating_in_single_segments_are_one_run():
    segs = [
        (0, 100, 1),
        (100, 300, 7),
        (300, 420, 3),
        (420, 550, 7),
        (550, 700, 3),
        (700, 900, 6),
        (900, 1000, 6),
    ]
    out = merge_alternations(segs)
    # 7, 3, 7, 3 (each 3 a single segment) is one run of 7; 1 and 6 stay apart
    assert out == [
        (0, 100, 1),
        (100, 300, 7),
        (300, 420, 7),
        (420, 550, 7),
        (550, 700, 7),
        (700, 900, 6),
        (900, 1000, 6),
    ]
    assert _changes(out) == [100, 700]
    # ... ending on A, and longer A runs in between
    segs = [
        (0, 10, 1),
        (10, 20, 2),
        (20, 40, 1),
        (40, 50, 1),
        (50, 60, 2),
        (60, 70, 1),
        (70, 80, 5),
    ]
    assert _changes(merge_alternations(segs)) == [70]


def test_a_single_segment_between_two_runs_of_a_label_is_an_action_of_its_own():
    segs = [(0, 100, 1), (100, 200, 2), (200, 300, 1), (300, 400, 3)]  # A, B, A once
    assert merge_alternations(segs) == segs
    segs = [(0, 100, 1), (100, 200, 2), (200, 300, 2), (300, 400, 1), (400, 500, 2)]
    assert merge_alternations(segs) == segs  # the first B is two segments
    segs = [(0, 100, 1), (100, 200, 2), (200, 300, 3)]
    assert merge_alternations(segs) == segs
    assert merge_alternations([]) == []
    assert merge_alternations([(5, 9, 4)]) == [(5, 9, 4)]


def _relabel_take(rec, merge: bool):
    """The daemon's relabel of a whole take (one window, no previous revision)."""
    sk = rec.skeleton
    algorithms = Algorithms(settle_s=0, alternations=merge)
    pipe = StreamPipeline(
        skeleton_from(sk.names, sk.parents, sk.units, sk.up), rec.fps, algorithms, 60.0
    )
    for i in range(0, rec.n_frames, 240):
        pipe.push(rec.positions[i : i + 240], i)
    feats, frames = pipe.snapshot()
    return relabel(algorithms, feats, frames, rec.fps, None, tuple(pipe.cut_frames)).segments


def _share_near(frames, targets, tol) -> float:
    return sum(min(abs(f - t) for t in targets) <= tol for f in frames) / len(frames)


def test_the_daemons_relabel_of_a_real_take_merges_its_alternation(data_dir):
    """HDM05 bd's first join (four motions, labelled) relabelled whole as the daemon does:
    HACA's labels alternate inside one motion; merged, the segments tile the same frames,
    only label changes go, every labelled boundary still has a label change within 1.5 s,
    more of those left lie within 1.5 s of a labelled boundary, and no label alternates
    with another in single segments."""
    from streamseg.evaluation.labelled_sets import labelled_sets

    item = next(i for i in labelled_sets(data_dir, sets=("hdm",)) if i.name == "hdm_bd_1")
    rec, tol = item.recording, 1.5 * item.recording.fps
    plain, merged = _relabel_take(rec, False), _relabel_take(rec, True)
    assert [s[:2] for s in plain] == [s[:2] for s in merged]
    before, after = _changes(plain), _changes(merged)
    assert set(after) < set(before)
    assert _share_near(item.cuts, after, tol) == _share_near(item.cuts, before, tol) == 1.0
    assert _share_near(after, item.cuts, tol) > _share_near(before, item.cuts, tol)
    assert merge_alternations(merged) == list(merged)  # nothing left to merge
