"""Each step of Wang et al. 2015, section 4, on hand-built signals (issue 6)."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg.config import RepetitionConfig
from streamseg.evaluation.metrics import count_error, repetition_accuracy
from streamseg.exceptions import ParameterError
from streamseg.offline import repetition_steps as steps
from streamseg.offline.repetition import RepetitionSegmenter


def test_primary_frequency_of_a_sum_of_sines_is_the_strongest_common_frequency():
    fps, n = 50.0, 1000  # 20 s
    t = np.arange(n) / fps
    # 0.4 Hz (8 cycles) in all three parameters; 1.3 Hz only in one, with more amplitude there
    X = np.stack([1.0 * np.sin(2 * np.pi * 0.4 * t) + 1.2 * np.sin(2 * np.pi * 1.3 * t),
                  0.8 * np.sin(2 * np.pi * 0.4 * t + 1.0),
                  0.6 * np.cos(2 * np.pi * 0.4 * t)], axis=1)
    cycles, power = steps.power_spectrum(X, pad=4)
    i = steps.primary_frequency(cycles, power)
    assert cycles[i] == pytest.approx(8.0)
    assert cycles[i] * fps / n == pytest.approx(0.4)
    # a slow drift is not a repetition: bins under min_cycles are excluded
    drift = X + 2.0 * np.sin(2 * np.pi * 0.05 * t)[:, None]  # 1 cycle, most power
    cd, pd = steps.power_spectrum(drift, pad=4)
    assert cd[steps.primary_frequency(cd, pd, min_cycles=2.0)] == pytest.approx(8.0)
    with pytest.raises(ParameterError, match="too short"):
        steps.primary_frequency(cycles, power, min_cycles=600.0)


def test_select_parameters_takes_the_fewest_reaching_the_power_share():
    p = np.array([1.0, 6.0, 0.5, 2.5])  # shares sorted: 0.6, 0.85, 0.95, 1.0
    np.testing.assert_array_equal(steps.select_parameters(p, 0.9), [1, 3, 0])
    np.testing.assert_array_equal(steps.select_parameters(p, 0.85), [1, 3])
    np.testing.assert_array_equal(steps.select_parameters(p, 0.5), [1])
    np.testing.assert_array_equal(steps.select_parameters(p, 1.0), [1, 3, 0, 2])


def test_bandpass_keeps_the_primary_frequency_and_removes_others():
    fps, n = 100.0, 2000
    t = np.arange(n) / fps
    keep = np.sin(2 * np.pi * 0.5 * t)
    X = (keep + 0.8 * np.sin(2 * np.pi * 6.0 * t) + 0.05 * t)[:, None]
    Y = steps.bandpass(X, fps, 0.3, 0.8)
    mid = slice(300, 1700)
    assert np.max(np.abs(Y[mid, 0] - keep[mid])) < 0.1


def test_candidates_are_the_known_velocity_minima():
    n = 400
    t = np.arange(n)
    minima = [37, 121, 205, 290, 371]
    speed2 = np.ones(n)
    for m in minima:
        speed2 -= 0.9 * np.exp(-0.5 * ((t - m) / 6.0) ** 2)
    found = steps.candidate_points(speed2, window=40)
    np.testing.assert_array_equal(found, minima)
    with pytest.raises(ParameterError):
        steps.candidate_points(speed2, window=2)


def test_kmeans_cost_by_hand():
    V = np.array([[0.0], [2.0], [10.0]])
    labels = np.array([0, 0, 1])
    centers = np.array([[1.0], [10.0]])
    cost, intra, inter = steps.kmeans_cost(V, labels, centers)
    assert intra == 2.0  # 1 + 1 + 0
    assert inter == 162.0  # 81 counted for (0,1) and (1,0)
    assert cost == pytest.approx(2.0 + 3 / 4 * 162.0)


def test_adaptive_kmeans_never_mixes_separated_phases_and_follows_eq13():
    rng = np.random.default_rng(0)
    V = np.concatenate([c + 0.03 * rng.normal(size=(8, 2)) for c in ([0.0, 0.0], [1.0, 1.0])])
    labels, k = steps.adaptive_kmeans(V, k_max=10, seed=0)
    assert 2 <= k <= 10 and np.unique(labels).size == k
    assert not set(labels[:8]) & set(labels[8:])  # every cluster within one phase
    # Eq. 13 by hand for this data: K = 2 (the two phases) costs
    # intra(2) + 16/4 * inter(2); splitting a tight phase in two adds ~0 to inter but divides
    # lambda by 9/4, so K* = 3 is cheaper: the paper's criterion, reproduced.
    two = np.repeat([0, 1], 8)
    c2 = np.array([V[two == g].mean(axis=0) for g in range(2)])
    ck = np.array([V[labels == g].mean(axis=0) for g in range(k)])
    assert steps.kmeans_cost(V, labels, ck)[0] < steps.kmeans_cost(V, two, c2)[0]
    assert k == 3
    assert steps.adaptive_kmeans(V[:2])[1] == 1  # fewer than three candidates: one group


def test_merge_same_phase_joins_clusters_of_one_phase_only():
    # four clusters: two at phase 0 (early and late repetitions), two at phase pi
    P = np.array([[1.0, 0.9], [0.95, 1.0], [1.0, 0.8], [0.9, 0.95],
                  [-1.0, -0.9], [-0.9, -1.0], [-0.8, -1.0], [-1.0, -0.95]])
    labels = np.array([0, 0, 1, 1, 2, 2, 3, 3])
    merged = steps.merge_same_phase(P, labels, 0.6)
    np.testing.assert_array_equal(merged, [0, 0, 0, 0, 1, 1, 1, 1])
    np.testing.assert_array_equal(steps.merge_same_phase(P, labels, 0.0), labels)


def test_select_group_prefers_span_then_rest_pose():
    points = np.array([10, 50, 110, 150, 210, 250, 300])
    labels = np.array([0, 1, 0, 1, 0, 1, 2])
    # group 2 has one point: spans far less than one period each side -> never chosen
    assert steps.select_group(points, labels, 320, period=100) in (0, 1)
    # groups 0 and 1 both span everything; the one nearer the rest pose wins the tie
    assert steps.select_group(points, labels, 320, 100, np.array([0.5, 0.1, 0.0])) == 1
    assert steps.select_group(points, labels, 320, 100, np.array([0.1, 0.5, 0.0])) == 0
    assert steps.group_span([50], 320, 100) == 151


def test_to_repetitions_fills_missed_boundaries_and_edges():
    # boundaries every 100 frames, the one at 400 missed, lead-in and tail one period each
    reps = steps.to_repetitions([100, 200, 300, 500, 600], 700, period=100)
    assert reps == [(0, 100), (100, 200), (200, 300), (300, 400), (400, 500), (500, 600),
                    (600, 700)]
    # a still lead-in (no activity) is not a repetition
    activity = np.ones(700)
    activity[:100] = 0.0
    reps = steps.to_repetitions([100, 200, 300, 400, 500, 600], 700, 100, activity=activity)
    assert reps[0] == (100, 200) and len(reps) == 6
    # a stretch shorter than edge_fraction periods is dropped; close points merge
    assert steps.to_repetitions([30, 40, 130, 230], 260, 100) == [(30, 130), (130, 230)]
    assert steps.to_repetitions([], 100, 50) == []


def test_alpha_and_count_error_by_hand():
    truth = [(0, 100), (100, 200), (200, 300)]
    assert repetition_accuracy(truth, truth) == 1.0
    # lengths 90, 120 vs 100, 100: (1 - 0.1 + 1 - 0.2) / 2
    assert repetition_accuracy([(0, 90), (90, 210)], truth) == pytest.approx(0.85)
    # order of the lists does not matter, only time order
    assert repetition_accuracy([(90, 210), (0, 90)], truth) == pytest.approx(0.85)
    assert repetition_accuracy([], truth) == 0.0
    assert repetition_accuracy([(0, 300)], truth) == pytest.approx(-1.0)
    assert count_error(2, 3) == -1 and count_error(5, 3) == 2


def test_segmenter_on_trajectories_with_a_known_rhythm():
    fps = 60.0
    lengths = [70, 80, 75, 72, 78, 74]  # frames per repetition
    phase = np.concatenate([np.linspace(0, 2 * np.pi, L, endpoint=False) for L in lengths])
    # a joint that bends and returns once per repetition, two others following it
    X = np.stack([0.5 * (1 - np.cos(phase)), 0.3 * (1 - np.cos(phase)), 0.2 * np.sin(phase),
                  0.01 * np.random.default_rng(0).normal(size=phase.size)], axis=1)
    seg = RepetitionSegmenter(fps=fps).fit(X)
    truth = list(zip(np.cumsum([0] + lengths[:-1]), np.cumsum(lengths)))
    assert seg.count_ == 6
    assert repetition_accuracy(seg.repetitions_, truth) > 0.9
    assert seg.primary_frequency_hz_ == pytest.approx(fps / np.mean(lengths), rel=0.05)
    segs = seg.predict()
    assert [(s.start, s.end) for s in segs] == seg.repetitions_ and segs[-1].label == 5
    labels = seg.labels_
    assert labels.shape == (phase.size,) and labels.max() == 5
    assert (labels[segs[2].start:segs[2].end] == 2).all()
    with pytest.raises(ParameterError, match="fps"):
        RepetitionSegmenter(fps=0)
    from streamseg.exceptions import NotFittedError

    with pytest.raises(NotFittedError):
        RepetitionSegmenter().predict()


def test_config_rejects_bad_values_naming_the_field():
    with pytest.raises(ParameterError, match="power_ratio"):
        RepetitionConfig(power_ratio=1.5)
    with pytest.raises(ParameterError, match="ukf_passes"):
        RepetitionConfig(ukf_passes=3)
    with pytest.raises(ParameterError, match="hop_s"):
        RepetitionConfig(hop_s=20.0, buffer_s=10.0)
    with pytest.raises(ParameterError, match="bandpass_width_cycles"):
        RepetitionConfig(bandpass_width_cycles=0.0)
    with pytest.raises(ParameterError, match="merge_edges"):
        RepetitionConfig(merge_edges="yes")


def test_to_repetitions_merges_short_edge_stretches_into_the_edge_repetitions():
    # points 0.2 period after the start and 0.3 before the end: with merge_edges those
    # stretches are the rest of the first / last repetition, which then reach the ends
    pts = [20, 120, 220, 320]
    assert steps.to_repetitions(pts, 350, 100, 0.7) == [(20, 120), (120, 220), (220, 320)]
    assert steps.to_repetitions(pts, 350, 100, 0.7, merge_edges=True) == [
        (0, 120), (120, 220), (220, 350)]
    # a merged edge gap holding two cycles (a missed boundary) is still split by the rhythm
    assert steps.to_repetitions([30, 230, 330], 340, 100, 0.7, merge_edges=True) == [
        (0, 115), (115, 230), (230, 340)]
    # a long still lead-in is neither a repetition nor merged: the first one starts at 100
    activity = np.ones(500)
    activity[:100] = 0.0
    reps = steps.to_repetitions([100, 200, 300, 400], 500, 100, 0.7, activity,
                                merge_edges=True)
    assert reps == [(100, 200), (200, 300), (300, 400), (400, 500)]


def test_select_group_short_sequence_rest_group_missing_an_edge_point():
    # three cycles of 25 frames: the rest-pose group (26, 50) lacks a point near the start
    # and spans 75 of 80 frames (94 %) against 80 for the other phase (12, 38, 63)
    points = np.array([12, 26, 38, 50, 63])
    labels = np.array([0, 1, 0, 1, 0])
    rest = np.array([0.5, 0.1])
    assert steps.group_span([26, 50], 80, 25) == 75
    assert steps.select_group(points, labels, 80, 25, rest, tie_tolerance=0.05) == 0
    assert steps.select_group(points, labels, 80, 25, rest, tie_tolerance=0.1) == 1
    assert RepetitionConfig().tie_tolerance >= 0.1 - 1e-12


def test_wider_bandpass_lets_boundaries_follow_uneven_repetitions():
    fps = 60.0
    lengths = [60, 100, 70, 110, 60, 95]  # repetitions of quite different lengths
    phase = np.concatenate([np.linspace(0, 2 * np.pi, L, endpoint=False) for L in lengths])
    X = np.stack([0.5 * (1 - np.cos(phase)), 0.3 * (1 - np.cos(phase)), 0.2 * np.sin(phase),
                  0.01 * np.random.default_rng(0).normal(size=phase.size)], axis=1)
    truth = list(zip(np.cumsum([0] + lengths[:-1]), np.cumsum(lengths)))
    true_joins = np.cumsum(lengths)[:-1]

    def join_error(width, align="none"):  # the spectral boundaries alone
        cfg = RepetitionConfig(bandpass_width_cycles=width, align=align)
        seg = RepetitionSegmenter(cfg, fps).fit(X)
        assert seg.count_ == len(lengths)
        found = np.array([b for _, b in seg.repetitions_[:-1]])
        return np.mean(np.abs(found - true_joins)), repetition_accuracy(seg.repetitions_, truth)

    err_default, alpha_default = join_error(RepetitionConfig().bandpass_width_cycles)
    err_paper, alpha_paper = join_error(3.0)  # the paper's band: near-even spacing
    assert err_default < 3.0 < err_paper
    assert alpha_default > 0.94 > alpha_paper
    # the DTW re-cut (the default, align="dtw") follows them even from the paper's band
    err_dtw, alpha_dtw = join_error(3.0, align="dtw")
    assert err_dtw < 3.0 and alpha_dtw > 0.94


def test_analyse_with_a_given_primary_uses_that_bin():
    from streamseg.offline.rep_analysis import analyse

    fps, lengths = 60.0, [70, 80, 75, 72, 78, 74]
    phase = np.concatenate([np.linspace(0, 2 * np.pi, L, endpoint=False) for L in lengths])
    X = np.stack([0.5 * (1 - np.cos(phase)), 0.2 * np.sin(phase)], axis=1)
    own = analyse(X, fps)
    assert own.primary_cycles == pytest.approx(6.0, abs=0.25)
    same = analyse(X, fps, primary_cycles=own.primary_cycles)
    assert same.primary_cycles == own.primary_cycles
    assert np.array_equal(same.boundaries, own.boundaries)
    half = analyse(X, fps, primary_cycles=own.primary_cycles / 2)
    assert half.primary_cycles == pytest.approx(own.primary_cycles / 2, abs=0.125)  # bin 1/4
    assert half.period == pytest.approx(2 * own.period, rel=0.05)
