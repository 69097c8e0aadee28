"""The repetition counter's behaviour: tempo, sets, honest edge cases, the command line."""

from __future__ import annotations

import json

import numpy as np
import pytest

from streamseg.cli import main
from streamseg.config import RepetitionConfig
from streamseg.evaluation.datasets import hdm05_clips
from streamseg.exceptions import ParameterError
from streamseg.io import read
from streamseg.offline.repetition import RepetitionSegmenter
from streamseg.online.repetition import RepetitionCounter
from streamseg.recording import Recording


def _bd(data_dir, cls, takes):
    asf = data_dir / "hdm05_reps" / "asf" / "HDM_bd.asf"
    paths = hdm05_clips(data_dir)["bd", cls]
    return [read(paths[t], skeleton=asf) for t in takes]


def _join(recs):
    return Recording(120.0, recs[0].skeleton, np.concatenate([r.positions for r in recs]))


def _loops(periods_s, fps=30.0, rest_s=0.0):
    """Feature rows tracing a closed loop once per period (a rest before each)."""
    rows = []
    for p in periods_s:
        rows.append(np.tile([1.6, 0.0, 0.0], (int(rest_s * fps), 1)))
        u = np.linspace(0, 2 * np.pi, int(p * fps), endpoint=False)
        rows.append(np.column_stack([1.6 * np.cos(u), 1.2 * np.sin(u), 0.4 * np.sin(2 * u)]))
    return np.concatenate(rows + [np.array([[1.6, 0.0, 0.0]])])


def test_a_tempo_that_doubles_inside_a_set_is_followed():
    periods = np.linspace(1.0, 2.2, 8)
    seg = RepetitionSegmenter(fps=30.0).fit(_loops(periods))
    assert [s["count"] for s in seg.sets_] == [8]
    st = seg.sets_[0]
    assert st["tempo_min_s"] == pytest.approx(1.0, abs=0.15)
    assert st["tempo_max_s"] == pytest.approx(2.2, abs=0.3)
    durations = [(b - a) / 30.0 for a, b in st["repetitions"]]
    assert np.all(np.diff(durations[1:-1]) > -0.1)  # slowing down, cycle by cycle


def test_rests_of_different_lengths_between_repetitions_stay_one_set():
    X = np.concatenate([_loops([1.0], rest_s=r)[:-1] for r in (0.3, 2.0, 0.6, 1.5, 0.2)])
    seg = RepetitionSegmenter(fps=30.0).fit(X)
    assert [s["count"] for s in seg.sets_] == [5]


@pytest.mark.parametrize(
    "cls,n",
    [
        ("hopBothLegs1hops", 2),
        ("hopBothLegs1hops", 3),
        ("hopBothLegs1hops", 4),
        ("rotateArmsBothBackward1Reps", 2),
    ],
)
def test_a_still_rest_between_real_repetitions_is_no_part_of_their_duration(data_dir, cls, n):
    """bd's takes with the last pose held 1, 1.5, 2 s between them: one set of all. (A loop
    is compared by its moving frames; with ``still_ratio=0`` these sets are missed or cut
    short: 0, 2, 3 hops and 0 arm circles.)"""
    reps = _bd(data_dir, cls, range(n))
    parts = []
    for i, r in enumerate(reps):
        parts.append(r)
        if i < n - 1:
            held = np.repeat(r.positions[-1:], int((1.0 + 0.5 * i) * 120), axis=0)
            parts.append(Recording(120.0, r.skeleton, held))
    seg = RepetitionSegmenter().fit(_join(parts))
    assert [s["count"] for s in seg.sets_] == [n]


def test_two_exercises_back_to_back_are_two_sets(data_dir):
    rec = _join(
        _bd(data_dir, "squat1Reps", range(4))
        + _bd(data_dir, "rotateArmsBothBackward1Reps", range(4))
    )
    seg = RepetitionSegmenter().fit(rec)
    assert [s["count"] for s in seg.sets_] == [4, 4]


def test_a_pause_ends_a_set(data_dir):
    squats = _bd(data_dir, "squat1Reps", range(6))
    still = Recording(
        120.0, squats[0].skeleton, np.repeat(squats[2].positions[-1:], int(4.5 * 120), axis=0)
    )
    seg = RepetitionSegmenter().fit(_join(squats[:3] + [still] + squats[3:]))
    assert [s["count"] for s in seg.sets_] == [3, 3]
    assert seg.sets_[0]["end_reason"] == "pause"


def test_a_still_recording_has_no_set_and_says_why(data_dir):
    squat = _bd(data_dir, "squat1Reps", [0])[0]
    still = Recording(120.0, squat.skeleton, np.repeat(squat.positions[:1], 600, axis=0))
    seg = RepetitionSegmenter().fit(still)
    assert seg.count_ == 0 and not seg.repetitive_
    assert seg.reason_.startswith("no movement as large as a repetition")


@pytest.mark.parametrize("n, why", [(0, "too short: 0 frames"), (1, "too short: 1 frame")])
def test_a_take_too_short_has_no_set(data_dir, n, why):
    squat = _bd(data_dir, "squat1Reps", [0])[0]
    seg = RepetitionSegmenter().fit(Recording(120.0, squat.skeleton, squat.positions[:n]))
    assert seg.count_ == 0 and seg.reason_ == why


def test_nan_frames_are_bridged_and_counted_the_same(data_dir):
    rec = _join(_bd(data_dir, "squat1Reps", range(4)))
    want = RepetitionSegmenter().fit(rec)
    pos = rec.positions.copy()
    pos[200:204] = np.nan
    got = RepetitionSegmenter().fit(Recording(120.0, rec.skeleton, pos))
    assert got.n_missing_frames_ == 4 and got.count_ == want.count_ == 4
    nan = Recording(120.0, rec.skeleton, np.full_like(pos[:50], np.nan))
    seg = RepetitionSegmenter().fit(nan)
    assert seg.count_ == 0 and "missing" in seg.reason_


def test_bad_input_is_refused_with_a_clear_message():
    with pytest.raises(ParameterError, match="frame rate"):
        RepetitionCounter(fps=0)
    c = RepetitionCounter(fps=30.0, skeleton=["root", "lhipjoint"])
    with pytest.raises(ParameterError, match=r"shape \(n, 2, 3\)"):
        c.learn_many(np.zeros((3, 5, 3)))
    with pytest.raises(ParameterError, match=r"return_ratio=1.5 is invalid: expected a number"):
        RepetitionConfig(return_ratio=1.5)
    with pytest.raises(ParameterError, match="max_cycle_s"):
        RepetitionConfig(buffer_s=5.0)


def test_cli_segment_prints_each_set_and_draws_it(data_dir, tmp_path, capsys):
    rec = _join(_bd(data_dir, "squat1Reps", range(3)) + _bd(data_dir, "kickLFront1Reps", range(4)))
    from streamseg.io import write_npz

    f = tmp_path / "routine.npz"
    write_npz(f, rec)
    png = tmp_path / "reps.png"
    assert main(["segment", str(f), "--method", "rep", "--json", "--plot", str(png)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [s["count"] for s in out["sets"]] == [3, 4] and out["count"] == 7
    for st in out["sets"]:
        assert st["label"] is not None and 0 < st["confidence"] <= 1
        assert 0 < st["tempo_min_s"] <= st["tempo_max_s"] < 3
        assert len(st["repetitions"]) == st["count"]
    assert png.stat().st_size > 10_000
    assert main(["segment", str(f), "--method", "rep", "--rep-no-labels"]) == 0
    table = capsys.readouterr().out.splitlines()
    assert table[1].split()[-4:] == ["s", "per", "repetition", "confidence"]
    assert [line.split()[4] for line in table[2:4]] == ["3", "4"]


def test_cli_eval_scores_each_labelled_set(data_dir, tmp_path, capsys):
    recs = _bd(data_dir, "squat1Reps", range(3)) + _bd(data_dir, "throwBasketball", [0])
    rec = _join(recs)
    from streamseg.io import write_npz

    write_npz(tmp_path / "take.npz", rec)
    ends = np.cumsum([r.n_frames for r in recs])
    rows = ["sequence,start_frame,end_frame,action_label"]
    for i, (a, b) in enumerate(zip([0, *ends[:-1]], ends)):
        rows.append(f"take,{a + 1},{b},{'squat' if i < 3 else 'throw'}")
    (tmp_path / "labels.csv").write_text("\n".join(rows) + "\n")
    assert (
        main(
            [
                "eval",
                str(tmp_path / "take.npz"),
                "--method",
                "rep",
                "--labels",
                str(tmp_path / "labels.csv"),
                "--json",
            ]
        )
        == 0
    )
    out = json.loads(capsys.readouterr().out)
    assert out["exact_sets"] == "1 of 1" and out["actions_counted_zero"] == "1 of 1"
    assert out["alpha"] > 0.85 and out["true_count"] == 3


def test_cli_feature_matrix_needs_its_frame_rate(tmp_path, capsys):
    np.save(tmp_path / "x.npy", _loops([1.0] * 4))
    assert main(["segment", str(tmp_path / "x.npy"), "--method", "rep"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--fps" in err[0]
    assert (
        main(["segment", str(tmp_path / "x.npy"), "--method", "rep", "--fps", "30", "--json"]) == 0
    )
    assert json.loads(capsys.readouterr().out)["count"] == 4


def test_cli_says_once_which_frames_were_missing(data_dir, tmp_path, capsys):
    from streamseg.io import write_npz

    rec = _join(_bd(data_dir, "squat1Reps", range(4)))
    pos = rec.positions.copy()
    pos[200:260] = np.nan
    write_npz(tmp_path / "gappy.npz", Recording(120.0, rec.skeleton, pos))
    assert main(["segment", str(tmp_path / "gappy.npz"), "--method", "rep", "--json"]) == 0
    captured = capsys.readouterr()
    out, err = json.loads(captured.out), captured.err.strip().splitlines()
    assert out["count"] == 4 and out["n_nan_frames"] == 60
    assert len(err) == 1 and "warning" in err[0] and "60" in err[0]
