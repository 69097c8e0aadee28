"""``eval --method rep --rep-sets``: a routine scored per labelled set (issue 14).

Material: an HDM05 routine of actor bd joined from real clips in data/ (squat x5, deposit,
elbow-to-knee x5, grab, two-leg hop x5, throw, front kick x5; every join abrupt), labelled
one row per clip: a repetition in a set, or a whole action take.
"""

from __future__ import annotations

import json

import pytest

from streamseg.cli import main
from streamseg.commands.output import format_evaluation
from streamseg.commands.rep import score_sets, true_sets
from streamseg.evaluation.datasets import concatenate, hdm05_clips
from streamseg.evaluation.labels import LabelSegment
from streamseg.io import read, write_npz

ROUTINE = (("squat1Reps", 5), ("depositFloorR", 1), ("elbowToKnee1RepsLelbowStart", 5),
           ("grabHighR", 1), ("hopBothLegs1hops", 5), ("throwBasketball", 1),
           ("kickLFront1Reps", 5))


def test_true_sets_group_consecutive_rows_and_score_by_middle_frame():
    rows = [LabelSegment(a, b, lab, b, b) for a, b, lab in
            [(0, 10, "sq"), (10, 20, "sq"), (20, 30, "sq"), (30, 45, "throw"), (45, 55, "sq")]]
    sets = true_sets(rows)
    assert [(s, e, lab, len(r)) for s, e, lab, r in sets] == [
        (0, 30, "sq", 3), (30, 45, "throw", 1), (45, 55, "sq", 1)]
    found = [(0, 11), (11, 19), (19, 31), (31, 44)]  # the last one inside the throw
    got = score_sets(found, sets)
    assert [(g["true_count"], g["count"], g["count_error"]) for g in got] == [
        (3, 3, 0), (0, 1, 1), (0, 0, 0)]
    assert got[0]["alpha"] == pytest.approx(1 - (1 / 10 + 2 / 10 + 2 / 10) / 3)
    assert got[1]["alpha"] is None and got[2]["alpha"] is None


def test_cli_scores_a_labelled_routine_per_set(data_dir, tmp_path, capsys):
    clips = hdm05_clips(data_dir)
    asf = data_dir / "hdm05_reps" / "asf" / "HDM_bd.asf"
    recs, rows = [], []
    n = 0
    for cls, k in ROUTINE:
        for path in clips["bd", cls][:k]:
            r = read(path, skeleton=asf)
            recs.append(r)
            rows.append(f"routine,{n + 1},{n + r.n_frames},{cls}")  # 1-based, inclusive
            n += r.n_frames
    take, _ = concatenate(recs)
    write_npz(tmp_path / "routine.npz", take)
    labels = tmp_path / "labels.csv"
    labels.write_text("sequence,start_frame,end_frame,action_label\n" + "\n".join(rows) + "\n")
    assert main(["eval", str(tmp_path / "routine.npz"), "--method", "rep", "--rep-sets",
                 "--labels", str(labels), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    sets = out["sets"]
    assert [s["label"] for s in sets] == [c for c, _ in ROUTINE]
    assert [s["true_count"] for s in sets] == [5, 0, 5, 0, 5, 0, 5]
    assert out["true_count"] == 20 and out["count"] == sum(s["count"] for s in sets)
    for s in sets:
        if s["true_count"]:
            # measured: counts 5, 5, 6, 4; alpha 0.94, 0.86, 0.86, 0.61
            assert abs(s["count_error"]) <= 1 and s["alpha"] >= 0.5, s
        else:
            assert s["count"] == 0, s  # an action take holds no repetition
    assert int(out["exact_sets"].split()[0]) >= 2  # measured 2 of 4 (squats, elbow-to-knee)
    assert out["actions_counted_zero"] == "3 of 3"
    text = format_evaluation(out).splitlines()  # the readable form: one line per set
    first = text.index("  sets:") + 2
    assert [ln.split()[-1] for ln in text[first:first + 7]] == [c for c, _ in ROUTINE]
