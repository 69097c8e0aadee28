"""ACA: DP step against brute force, kernel k-means special case, descent and restarts."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from streamseg._kernels.aca import candidate_sums, relax
from streamseg._kernels.dtak import segment_kernel
from streamseg.evaluation.metrics import matched_frame_accuracy
from streamseg.exceptions import ParameterError
from streamseg.offline.aca import (
    NEG,
    ACAEngine,
    cluster_stats,
    dp_step,
    feasible_min_len,
    objective,
    reseed_empty,
)
from streamseg.offline.aca_init import random_tiling
from streamseg.offline.dtak import frame_kernel
from tests.naive import (
    naive_dist,
    naive_dp,
    naive_forward_dp,
    naive_kernel_kmeans,
    naive_objective,
)


def _problem(seed, n, k, wmin, wmax, binary=False):
    rng = np.random.default_rng(seed)
    if binary:
        K = frame_kernel(rng.integers(0, 3, n), kernel="equality")
    else:
        K = frame_kernel(rng.normal(size=(n, 2)), sigma=1.0)
    starts, ends = random_tiling(n, wmin, wmax, rng)
    labels = rng.integers(0, k, starts.size)
    labels[: min(k, starts.size)] = np.arange(min(k, starts.size))
    return K, starts, ends, labels.astype(np.int64)


def _dp(K, starts, ends, labels, k, wmin, wmax, variant):
    """The DP step with the given work dtype, old segments in the given (unsorted) order
    only when they are already sorted as dp_step sorts them."""
    T = segment_kernel(K, starts, ends)
    n_c, const = cluster_stats(T, labels, k)
    if variant == "step":
        return dp_step(K, starts, ends, labels, n_c, const, wmin, wmax)
    dtype = {"int16": np.int16, "int8": np.int8}.get(variant, np.float64)
    order = np.lexsort((labels, starts - ends))
    n = K.shape[0]
    work = [np.empty((wmax + 1, n + 1), dtype) for _ in range(2)]
    acc = np.empty((wmax + 1, n + 1), np.float64 if dtype == np.float64 else np.int64)
    F = np.zeros((k, wmax + 1, n + 1))
    candidate_sums(
        K.astype(dtype),
        starts[order],
        ends[order],
        labels[order],
        np.ones(starts.size, np.int64),
        wmin,
        wmax,
        *work,
        acc,
        F,
        NEG[dtype],
    )
    return relax(F, n_c, const, wmin, wmax)


CASES = [(0, 9, 2, 2, 4), (1, 10, 3, 1, 3), (2, 11, 2, 3, 5), (3, 8, 3, 1, 8)]


@pytest.mark.parametrize("variant", ["step", "float64", "int16", "int8"])
@pytest.mark.parametrize("seed,n,k,wmin,wmax", CASES)
def test_dp_equals_brute_force(seed, n, k, wmin, wmax, variant):
    # integer work arrays are only used (and only exact) for a 0/1 frame kernel
    K, starts, ends, labels = _problem(seed, n, k, wmin, wmax, binary=variant in ("int16", "int8"))
    ns, ne, nl, cost = _dp(K, starts, ends, labels, k, wmin, wmax, variant)
    old = list(zip(starts.tolist(), ends.tolist(), strict=True))
    assert cost == pytest.approx(naive_dp(K, old, labels.tolist(), k, wmin, wmax), abs=1e-9)
    # the returned segmentation tiles 0..n within the lengths and costs what the DP says
    assert ns[0] == 0 and ne[-1] == n and np.array_equal(ns[1:], ne[:-1])
    assert np.all((ne - ns >= wmin) & (ne - ns <= wmax))
    again = sum(
        naive_dist(K, (s, e), old, labels.tolist(), c) for s, e, c in zip(ns, ne, nl, strict=True)
    )
    assert again == pytest.approx(cost, abs=1e-9)


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 10**6),
    n=st.integers(6, 40),
    k=st.integers(1, 4),
    wmin=st.integers(1, 4),
    extra=st.integers(0, 5),
)
def test_dp_never_worse_than_a_random_segmentation(seed, n, k, wmin, extra):
    wmax = wmin + extra
    wmin = feasible_min_len(n, wmin, wmax)
    K, starts, ends, labels = _problem(seed, n, k, wmin, wmax)
    T = segment_kernel(K, starts, ends)
    n_c, const = cluster_stats(T, labels, k)
    _, _, _, cost = dp_step(K, starts, ends, labels, n_c, const, wmin, wmax)
    rng = np.random.default_rng(seed + 1)
    for _ in range(3):
        rs, re = random_tiling(n, wmin, wmax, rng)
        if not np.all((re - rs >= wmin) & (re - rs <= wmax)):
            continue
        rl = rng.integers(0, k, rs.size)
        rl = np.where(n_c[rl] > 0, rl, labels[0])
        # cost (eq. 3 summed) of the random segmentation under the same (old) centres
        total = 0.0
        for s, e, c in zip(rs, re, rl, strict=True):
            to_old = segment_kernel(K, np.r_[s, starts], np.r_[e, ends])[0, 1:]
            total += 1 - 2 * to_old[labels == c].sum() / n_c[c] + const[c]
        assert cost <= total + 1e-9


@pytest.mark.parametrize("binary", [False, True])
@pytest.mark.parametrize("long_old", [False, True])
def test_dp_step_equals_the_forward_recursion(binary, long_old):
    # a realistic segment count, old segments unsorted; with long_old one old segment is
    # longer than wmax (as after an initialization), which takes int16 tables for 0/1
    K, starts, ends, labels = _problem(12, 70, 3, 6, 12, binary=binary)
    if long_old:
        starts, ends = np.r_[0, ends[ends > 50][:-1]], np.r_[ends[ends > 50]]
        labels = labels[: starts.size] % 3
        labels[:3] = [0, 1, 2]
    T = segment_kernel(K, starts, ends)
    n_c, const = cluster_stats(T, labels, 3)
    ns, ne, nl, cost = dp_step(K, starts, ends, labels, n_c, const, 6, 12)
    old = list(zip(starts.tolist(), ends.tolist(), strict=True))
    want, segs = naive_forward_dp(K, old, labels.tolist(), 3, 6, 12)
    assert cost == pytest.approx(want, abs=1e-9)
    assert [tuple(x) for x in zip(ns.tolist(), ne.tolist(), nl.tolist())] == segs


def test_min_len_one_equals_kernel_kmeans():
    rng = np.random.default_rng(3)
    X = np.concatenate(
        [rng.normal(0, 1, (20, 2)), rng.normal(3, 1, (20, 2)), rng.normal((0, 4), 1, (20, 2))]
    )
    K = frame_kernel(X, sigma=1.5)
    for trial in range(3):
        init_lab = np.random.default_rng(trial).integers(0, 3, 60)
        init = [(i, i + 1, int(c)) for i, c in enumerate(init_lab)]
        model = ACAEngine(3, 1, 1, n_init=1, kernel="precomputed", init=init).fit(K)
        ref = naive_kernel_kmeans(K, init_lab, 3)
        np.testing.assert_array_equal(model.labels_, ref)


def test_objective_formula_matches_naive_definition():
    K, starts, ends, labels = _problem(5, 12, 2, 2, 4)
    T = segment_kernel(K, starts, ends)
    segs = list(zip(starts.tolist(), ends.tolist(), strict=True))
    assert objective(T, labels, 2) == pytest.approx(naive_objective(K, segs, labels.tolist()))


def _three_class_sequence(rng, n_segments=12):
    protos = [np.array([1, 2, 3, 4]), np.array([7, 7, 8, 9, 9]), np.array([12, 11, 10])]
    xs, ys = [], []
    prev = -1
    for _ in range(n_segments):
        c = int(rng.choice([c for c in range(3) if c != prev]))
        prev = c
        w = int(rng.integers(6, 10))
        idx = np.floor(np.linspace(0, len(protos[c]), w, endpoint=False)).astype(int)
        xs.extend(protos[c][idx])
        ys.extend([c] * w)
    return np.asarray(xs, float), np.asarray(ys)


def test_aca_recovers_clean_warped_sequence():
    x, y = _three_class_sequence(np.random.default_rng(0))
    model = ACAEngine(3, 6, 9, n_init=5, kernel="equality", random_state=0).fit(x)
    acc, _ = matched_frame_accuracy(model.labels_, y)
    assert acc == 1.0
    # segments tile the sequence with lengths in range and per-frame labels agree
    segs = model.segments_
    assert segs[0][0] == 0 and segs[-1][1] == len(x)
    assert all(a[1] == b[0] for a, b in zip(segs[:-1], segs[1:], strict=True))
    for s, e, lab in segs:
        assert np.all(model.labels_[s:e] == lab)


def test_restarts_keep_lowest_objective_and_descent_is_monotone():
    x, _ = _three_class_sequence(np.random.default_rng(1), 10)
    objs = [
        ACAEngine(3, 6, 9, n_init=1, kernel="equality", random_state=s).fit(x).objective_
        for s in range(6)
    ]
    # n_init=6 with seed 0 begins with exactly the restart of n_init=1 with seed 0
    best = ACAEngine(3, 6, 9, n_init=6, kernel="equality", random_state=0).fit(x)
    assert best.objective_ <= objs[0] + 1e-12
    # six restarts were run and the kept one is the lowest of them, whichever it was
    assert best.restart_objectives_.shape == (6,)
    assert best.restart_objectives_[0] == pytest.approx(objs[0])
    assert best.objective_ == best.restart_objectives_.min()
    assert np.unique(best.restart_objectives_).size > 1  # the restarts did differ
    K = frame_kernel(x, kernel="equality")
    rng = np.random.default_rng(4)
    from streamseg.offline.aca import descend
    from streamseg.offline.aca_init import random_init

    for _ in range(5):
        s0, e0, l0 = random_init(K, 3, 6, 9, rng)
        before = objective(
            segment_kernel(K, s0, e0), reseed_empty(segment_kernel(K, s0, e0), l0, 3), 3
        )
        *_, after, _ = descend(K, s0, e0, l0, 3, 6, 9, 50)
        assert after <= before + 1e-12


def test_empty_cluster_is_reseeded_not_a_crash():
    x, _ = _three_class_sequence(np.random.default_rng(2), 4)
    model = ACAEngine(6, 6, 9, n_init=3, kernel="equality", random_state=0).fit(x)
    assert set(model.labels_.tolist()) <= set(range(6))
    T = np.array([[1.0, 0.9, 0.1], [0.9, 1.0, 0.1], [0.1, 0.1, 1.0]])
    # cluster 1 empty: the segment farthest from its centre (index 2) moves there
    np.testing.assert_array_equal(reseed_empty(T, np.array([0, 0, 0]), 2), [0, 0, 1])


def test_infeasible_lengths_fall_back_to_min_len_one():
    assert feasible_min_len(5, 3, 4) == 1
    assert feasible_min_len(7, 3, 4) == 3
    model = ACAEngine(2, 3, 4, n_init=2, kernel="equality", random_state=0).fit(np.arange(5.0))
    assert model.min_len_used_ == 1 and model.labels_.shape == (5,)


@pytest.mark.parametrize(
    "kw,match",
    [
        ({"n_clusters": 0}, "n_clusters"),
        ({"min_len_frames": 5, "max_len_frames": 3}, "max_len_frames"),
        ({"kernel": "cosine"}, "kernel"),
        ({"init": "kmeans"}, "init"),
    ],
)
def test_parameter_errors(kw, match):
    params = {"n_clusters": 2, "min_len_frames": 2, "max_len_frames": 4} | kw
    with pytest.raises(ParameterError, match=match):
        ACAEngine(**params).fit(np.arange(10.0))
