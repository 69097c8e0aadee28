"""The DTW re-cut of repetitions against a template (issue 14, round 3): the kernels against
their slow twins, the mechanism on synthetic pauses, and a floor on real HDM05 clips of an
actor whose repetitions vary in length (dg's two-leg hops, 74-151 frames in one set)."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg._kernels.rep_align import best_tiling, open_end_costs
from streamseg.config import RepetitionConfig
from streamseg.evaluation.datasets import concatenate
from streamseg.evaluation.metrics import repetition_accuracy
from streamseg.exceptions import ParameterError
from streamseg.io import read
from streamseg.offline.rep_align import align_repetitions, dtw_cost
from streamseg.offline.repetition import RepetitionSegmenter
from tests.naive import naive_best_tiling_cost, naive_template_dtw


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("max_slope", [1, 2, 3])
@pytest.mark.parametrize("max_compress", [1, 2, 3])
def test_open_end_costs_match_the_path_enumeration(seed, max_slope, max_compress):
    rng = np.random.default_rng(seed)
    L, n, lo, hi = 7, 14, 2, 9
    dist = rng.random((L, n))
    C = open_end_costs(dist, lo, hi, max_slope, max_compress)
    for a in range(n):
        for m in range(1, hi + 1):
            if m < lo or a + m > n:
                assert C[a, m] == np.inf
            else:
                want = naive_template_dtw(dist, a, m, max_slope, max_compress)
                assert C[a, m] == pytest.approx(want)
                # a path exists exactly when the slopes allow m frames for L
                assert np.isfinite(C[a, m]) == (L <= max_compress * m and m <= max_slope * L)


@pytest.mark.parametrize("seed", [0, 1])
def test_best_tiling_is_the_least_cost_tiling(seed):
    rng = np.random.default_rng(seed)
    n, lo, hi = 13, 2, 5
    C = np.full((n, hi + 1), np.inf)
    C[:, lo:] = rng.random((n, hi + 1 - lo))
    cuts = best_tiling(C, n, lo, hi)
    assert cuts[0] == 0 and cuts[-1] == n
    assert np.all(np.diff(cuts) >= lo) and np.all(np.diff(cuts) <= hi)
    got = sum((b - a) * C[a, b - a] for a, b in zip(cuts[:-1], cuts[1:]))
    assert got == pytest.approx(naive_best_tiling_cost(C, n, lo, hi))
    assert best_tiling(C, 1, lo, hi).size == 0  # no tiling of one frame by pieces >= 2


def test_dtw_cost_of_a_stretched_copy_is_small_and_out_of_slope_is_inf():
    t = np.linspace(0, 2 * np.pi, 30)
    A = np.c_[np.sin(t), np.cos(t)]
    t2 = np.linspace(0, 2 * np.pi, 55)  # the same movement, slower
    B = np.c_[np.sin(t2), np.cos(t2)]
    assert dtw_cost(A, B) < 0.01 < dtw_cost(A, B[::-1])
    assert dtw_cost(A, B[:10]) == np.inf  # 10 frames cannot hold 30 at slope >= 1/2
    assert np.isfinite(dtw_cost(A, B[:10], max_compress=3))  # they can at slope >= 1/3
    with pytest.raises(ParameterError, match="same d"):
        dtw_cost(A, B[:, :1])


def _pauses_then_moves(pauses, move=40):
    """Repetitions = a pause at rest (0) of varying length, then one movement (a bump)."""
    parts, starts = [], []
    bump = np.sin(np.linspace(0, np.pi, move)) ** 2
    for p in pauses:
        starts.append(sum(len(x) for x in parts))
        parts.append(np.r_[np.zeros(p), bump])
    x = np.concatenate(parts)
    return np.c_[x, 0.5 * x], starts


def test_pauses_of_different_lengths_keep_one_movement_per_piece():
    """The rhythm (an even split) cuts through movements when the pauses differ; the
    re-cut puts every movement in a piece of its own."""
    F, starts = _pauses_then_moves([10, 60, 15, 5, 45, 20])
    n = F.shape[0]
    k = len(starts)
    even = [(round(i * n / k), round((i + 1) * n / k)) for i in range(k)]
    reps = align_repetitions(F, even, 30.0, rate_hz=30.0)
    assert len(reps) == k
    assert reps[0][0] == 0 and reps[-1][1] == n
    assert all(b == c for (_, b), (c, _) in zip(reps[:-1], reps[1:]))
    moves = [(s + p, s + p + 40) for s, p in zip(starts, [10, 60, 15, 5, 45, 20])]
    for (a, b), (ma, mb) in zip(reps, moves):
        assert a <= ma + 2 and mb - 2 <= b, (reps, moves)  # whole movement inside, 2 frames
    # the template that cut them (for rep_diagnosis --objective) is one of the pieces it
    # was chosen from: one movement, inside the stretch
    same, (ta, tb) = align_repetitions(F, even, 30.0, rate_hz=30.0, return_template=True)
    assert same == reps and 0 <= ta < tb <= n
    assert sum(ma >= ta - 2 and mb <= tb + 2 for ma, mb in moves) == 1


def test_edge_cases_are_left_alone():
    F, _ = _pauses_then_moves([10, 20])
    assert align_repetitions(F, [(0, 50)], 30.0) == [(0, 50)]  # one repetition
    assert align_repetitions(F, [(0, 50)], 30.0, return_template=True) == ([(0, 50)], None)
    assert align_repetitions(F, [], 30.0) == []
    with pytest.raises(ParameterError, match="stretch"):
        align_repetitions(F, [(0, 50), (50, 110)], 30.0, stretch=1.0)
    with pytest.raises(ValueError, match="align"):
        RepetitionConfig(align="spectral")


def test_varying_hops_of_an_unseen_actor(data_dir):
    """dg's two-leg hops (clips 138-74 frames, concatenated in take order; the joins are the
    true boundaries): the re-cut counts all 7 and keeps alpha above a floor. Measured: 7/7,
    alpha 0.944 (the spectral boundaries alone, align="none": 5/7, alpha 0.503)."""
    import csv

    root = data_dir / "hdm05_reps"
    with open(root / "clips.csv", newline="") as fh:
        files = [r["file"] for r in csv.DictReader(fh)
                 if r["class"] == "hopBothLegs1hops" and r["actor"] == "dg"]
    recs = [read(root / "hopBothLegs1hops" / (files[i] + ".gz"), skeleton=root / "asf" /
                 "HDM_dg.asf") for i in (0, 2, 3, 5, 6, 7, 8)]
    take, joins = concatenate(recs)
    bounds = [0, *joins, take.n_frames]
    truth = list(zip(bounds[:-1], bounds[1:]))
    seg = RepetitionSegmenter().fit(take)
    assert seg.count_ == 7
    assert repetition_accuracy(seg.repetitions_, truth) >= 0.85


def test_snap_to_a_place_in_the_pause():
    """The snap (align_snap): level 0 puts a cut on the window's minimum; a level above 0 at
    ``position`` of the pause around it (the frames within level x the window's range)."""
    from streamseg.offline.repetition import _snap

    curve = np.ones(100)
    curve[40:61] = 0.01  # a pause of frames 40..60 in the window around the cut at 50
    curve[44] = 0.0  # its minimum, off centre
    reps = [(0, 50), (50, 100)]
    assert _snap(reps, curve, 0.3) == [(0, 44), (44, 100)]
    assert _snap(reps, curve, 0.3, level=0.05, position=0.5) == [(0, 50), (50, 100)]
    assert _snap(reps, curve, 0.3, level=0.05, position=0.75) == [(0, 55), (55, 100)]
    assert _snap(reps, curve, 0.3, level=0.05, position=1.0) == [(0, 60), (60, 100)]
    # the pause is clipped to the window (0.3 x 50 = 15 frames either side of 50: 35..65)
    curve[30:61] = 0.01
    curve[44] = 0.0
    assert _snap(reps, curve, 0.3, level=0.05, position=0.0) == [(0, 35), (35, 100)]
    for bad in ({"align_snap_level": 1.0}, {"align_snap_level": -0.1},
                {"align_snap_position": 1.5}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            RepetitionConfig(**bad)
