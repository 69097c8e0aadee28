"""`segment/eval --method rep` on whole takes that are not (only) exercises, on takes with
missing frames and on takes too short to analyse: the real command, strict JSON
(audit findings 21-24, /work/notes/audit.md)."""

from __future__ import annotations

import json
import warnings
from dataclasses import replace

import numpy as np
import pytest

from streamseg.cli import main
from streamseg.config import RepetitionConfig
from streamseg.io import read
from streamseg.io.npz import write_npz
from streamseg.offline.rep_analysis import min_repetitions
from streamseg.offline.repetition import RepetitionSegmenter
from streamseg.online.repetition import RepetitionCounter
from streamseg.plotting.repetitions import title


def _run(capsys, argv):
    """Run the real command, no Python warning allowed; (exit code, strict JSON, stderr lines)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code = main([str(a) for a in argv])
    assert not caught, [str(w.message) for w in caught]
    cap = capsys.readouterr()
    out = json.loads(cap.out, parse_constant=lambda c: pytest.fail(f"non-strict JSON: {c}"))
    return code, out, cap.err.strip().splitlines()


@pytest.fixture(scope="module")
def take86(data_dir):
    return read(data_dir / "cmu86" / "86_01.amc.gz", data_dir / "cmu86" / "86.asf")


@pytest.fixture(scope="module")
def amc(data_dir):
    return [data_dir / "cmu86" / "86_01.amc.gz", "--skeleton", data_dir / "cmu86" / "86.asf"]


def _punches(data_dir):
    rows = [line.split(",") for line in
            (data_dir / "cmu86" / "labels_86_01.csv").read_text().splitlines()[1:]]
    return [(int(r[1]) - 1, int(r[2])) for r in rows if r[0] == "86_01" and r[3] == "punch"]


def _check_sets(out):
    need = min_repetitions(RepetitionConfig())
    for st in out["sets"]:
        if st["repetitive"]:
            assert st["count"] >= need and st["reason"] is None, st
        else:
            assert st["count"] == 0 and st["repetitions"] == [] and st["reason"], st
        assert st["count"] == len(st["repetitions"])
    rep = [st for st in out["sets"] if st["repetitive"]]
    assert out["count"] == sum(st["count"] for st in rep) == len(out["repetitions"])
    assert out["repetitive"] == bool(rep)


def test_a_set_of_fewer_than_three_repetitions_is_not_repetitive(capsys, amc, data_dir):
    # 86_01 is walk, jump, punch, kick: its punch sets were counted 2 and "repetitive"
    code, out, err = _run(capsys, ["segment", *amc, "--method", "rep", "--json"])
    assert code == 0, err
    _check_sets(out)
    assert not any(0 < st["count"] < 3 for st in out["sets"])
    rep = [st for st in out["sets"] if st["repetitive"]]
    assert title(None, out["sets"]) == (  # the picture says what the JSON says
        f"{out['count']} repetitions in {len(rep)} repetitive set(s) of {len(out['sets'])} "
        f"({', '.join(str(st['count']) for st in rep)})")
    for a, b in _punches(data_dir):
        inside = [st for st in out["sets"] if a <= (st["start"] + st["end"]) // 2 < b]
        assert inside and all(st["count"] == 0 and not st["repetitive"] for st in inside)
        assert any("found, fewer than 2.5 cycles" in st["reason"] for st in inside)


def test_nan_frames_are_skipped_with_one_warning_line(capsys, amc, take86, tmp_path):
    P = take86.positions.copy()
    P[1000:1100] = np.nan
    R = take86.rotations.copy()
    R[1000:1100] = np.nan
    path = tmp_path / "holes.npz"
    write_npz(path, replace(take86, positions=P, rotations=R))
    code, out, err = _run(capsys, ["segment", path, "--method", "rep", "--json"])
    assert code == 0, err
    assert out["n_nan_frames"] == 100 and out["n_frames"] == 4579
    assert len(err) == 1 and "1 gap without the joint positions" in err[0]
    assert "(frames 1000-1099; 100 frames, 0.83 s in all)" in err[0]
    assert "RuntimeWarning" not in err[0] and "skipped" in err[0]
    _check_sets(out)
    assert out["repetitive"] and out["count"] >= 3
    for st in out["sets"]:  # a hole does not make repetitions of its own
        for r in st["repetitions"]:
            assert not (1000 <= r["start"] and r["end"] <= 1100)
    # the command counts what it counts on the clean take
    _, clean, _ = _run(capsys, ["segment", *amc, "--method", "rep", "--json"])
    assert out["count"] == clean["count"]


@pytest.mark.parametrize("n, why", [(0, "too short: 0 frames"), (1, "too short: 1 frame"),
                                    (2, "too short: 2 frames"), (3, "too short: 3 frames")])
def test_a_take_too_short_gives_count_0_and_a_reason(capsys, take86, tmp_path, n, why):
    path = tmp_path / f"f{n}.npz"
    write_npz(path, replace(take86, positions=take86.positions[:n],
                            rotations=take86.rotations[:n]))
    png = tmp_path / "f.png"
    code, out, err = _run(capsys, ["segment", path, "--method", "rep", "--json",
                                   "--plot", png])
    assert code == 0, err
    assert out["count"] == 0 and out["repetitive"] is False and out["reason"] == why
    assert len(out["sets"]) == (1 if n else 0) and out["repetitions"] == []
    assert [line for line in err if "warning" in line] == [
        f"streamseg segment: warning: f{n}.npz does not look repetitive ({why}): count 0"]
    assert png.stat().st_size > 0


def test_a_still_take_and_an_all_nan_take(capsys, take86, tmp_path):
    still = tmp_path / "still.npz"
    write_npz(still, replace(take86, positions=np.repeat(take86.positions[:1], 600, axis=0),
                             rotations=np.repeat(take86.rotations[:1], 600, axis=0)))
    code, out, err = _run(capsys, ["segment", still, "--method", "rep", "--json"])
    assert code == 0 and out["count"] == 0 and out["repetitive"] is False
    assert out["reason"] == "no motion" and len(out["sets"]) == 1
    gone = tmp_path / "gone.npz"
    write_npz(gone, replace(take86, positions=np.full_like(take86.positions[:300], np.nan),
                            rotations=None))
    code, out, err = _run(capsys, ["segment", gone, "--method", "rep", "--json"])
    assert code == 0, err
    assert out["count"] == 0 and out["repetitive"] is False and out["n_nan_frames"] == 300
    assert "every frame (300) has missing (NaN) joint positions" in out["reason"]
    assert any("all 300 frames have NaN joint positions" in line for line in err)


def test_nan_rows_of_an_array_and_a_one_row_matrix(capsys, tmp_path):
    t = np.arange(1200) / 120.0
    m = np.stack([np.sin(2 * np.pi * 0.8 * t), np.cos(2 * np.pi * 0.8 * t)], axis=1)
    holes = m.copy()
    holes[300:310] = np.nan
    seg = RepetitionSegmenter(fps=120.0).fit(holes)  # the Python API bridges them too
    assert seg.n_missing_frames_ == 10 and seg.repetitive_ and seg.count_ >= 7
    # (the CLI's matrix reader refuses a NaN: "found non-finite value in row 300")
    np.save(tmp_path / "one.npy", m[:1])
    code, out, err = _run(capsys, ["segment", tmp_path / "one.npy", "--fps", "120",
                                   "--method", "rep", "--json"])
    assert code == 0 and out["count"] == 0 and out["reason"] == "too short: 1 frame"


def test_eval_without_rep_sets_says_why_its_count_differs(capsys, amc, data_dir):
    labels = data_dir / "cmu86" / "labels_86_01.csv"
    code, out, err = _run(capsys, ["eval", *amc, "--labels", labels, "--method", "rep",
                                   "--json"])
    assert code == 0, err
    assert out["count"] == 0 and out["repetitive"] is False and out["reason"]
    assert "not cut into action sets" in out["note"] and "--rep-sets" in out["note"]
    assert len(err) == 1 and "as one exercise does not look repetitive" in err[0]
    assert "segment --method rep" in err[0] and "--rep-sets" in err[0]


def test_a_two_piece_set_is_counted_neither_offline_nor_live(take86):
    # 86_01's last punch, alone: 2.5 spectral cycles, 2 pieces (both counted 2 before the rule)
    part = take86.slice(4043, 4579)
    off = RepetitionSegmenter().fit(part)
    assert off.count_ == 0 and not off.repetitive_ and "2 repetitions found" in off.reason_
    counter = RepetitionCounter(None, take86.fps, take86.skeleton)
    events = []
    for i in range(0, part.n_frames, 30):
        events += counter.learn_many(part.positions[i:i + 30])
    events += counter.finish()
    assert events == [] and counter.count_ == off.count_
