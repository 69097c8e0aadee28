"""The descent reads its statistics off the candidate table, and restarts share their
embedding: both against the plain computation on segment DTAK matrices."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg._kernels.dtak import segment_kernel
from streamseg.offline.aca import cluster_stats, dp_step, objective, reseed_empty
from streamseg.offline.aca_descent import descend
from streamseg.offline.aca_init import (
    OWN_EMBEDDING_MAX,
    RandomInits,
    random_init,
    random_tiling,
    tiling_kernel,
)
from streamseg.offline.dtak import frame_kernel


def plain_descend(K, starts, ends, labels, k, wmin, wmax, max_iter):
    """Coordinate descent with the segment DTAK matrix rebuilt at every step."""
    T = segment_kernel(K, starts, ends)
    it = 0
    while it < max_iter:
        it += 1
        labels = reseed_empty(T, labels, k)
        n_c, const = cluster_stats(T, labels, k)
        ns, ne, nl, _ = dp_step(K, starts, ends, labels, n_c, const, wmin, wmax)
        if (
            ns.shape == starts.shape
            and np.array_equal(ns, starts)
            and np.array_equal(ne, ends)
            and np.array_equal(nl, labels)
        ):
            break
        starts, ends, labels = ns, ne, nl
        T = segment_kernel(K, starts, ends)
    labels = reseed_empty(T, labels, k)
    return starts, ends, labels, objective(T, labels, k), it


@pytest.mark.parametrize("seed", range(12))
def test_descent_equals_the_plain_descent(seed):
    rng = np.random.default_rng(seed)
    n = 150
    if seed % 2:
        K = frame_kernel(rng.normal(size=(n, 2)), sigma=1.0)
    else:
        K = frame_kernel(rng.integers(0, 4, n), kernel="equality")
    k = 2 + seed % 4
    starts, ends = random_tiling(n, 5, 9, rng)
    labels = rng.integers(0, k, starts.size).astype(np.int64)
    labels[labels == k - 1] = 0  # an empty cluster to re-seed
    if seed % 3 == 0:  # initial segments out of [wmin, wmax]: the fallback sums
        starts[1] -= 1
    max_iter = 1 + seed % 4
    got = descend(K, starts, ends, labels, k, 5, 9, max_iter)
    want = plain_descend(K, starts, ends, labels, k, 5, 9, max_iter)
    for a, b in zip(got[:3], want[:3]):
        np.testing.assert_array_equal(a, b, err_msg=f"seed {seed}")
    assert got[4] == want[4]
    assert got[3] == pytest.approx(want[3], rel=1e-12, abs=1e-12)


def test_one_frame_tiling_kernel_is_the_frame_kernel():
    rng = np.random.default_rng(3)
    K = frame_kernel(rng.normal(size=(40, 3)), sigma=1.0)
    idx = np.arange(40)
    np.testing.assert_array_equal(tiling_kernel(K, idx, idx + 1), segment_kernel(K, idx, idx + 1))
    sub = np.array([1, 5, 9, 30])
    np.testing.assert_array_equal(tiling_kernel(K, sub, sub + 1), segment_kernel(K, sub, sub + 1))


def test_short_tilings_are_initialized_exactly_as_random_init():
    rng = np.random.default_rng(5)
    K = frame_kernel(rng.integers(0, 3, 300), kernel="equality")
    inits = RandomInits(K, 6, 9)
    a, b = np.random.default_rng(11), np.random.default_rng(11)
    for _ in range(3):
        for x, y in zip(inits(3, a), random_init(K, 3, 6, 9, b)):
            np.testing.assert_array_equal(x, y)


def test_long_tilings_share_one_embedding_and_restarts_differ():
    rng = np.random.default_rng(8)
    n = OWN_EMBEDDING_MAX + 200  # one-frame segments: every frame a segment
    x = np.repeat(rng.integers(0, 6, n // 10 + 1), 10)[:n]
    K = frame_kernel(x, kernel="equality")
    inits = RandomInits(K, 1, 1)
    a, b = np.random.default_rng(2), np.random.default_rng(2)
    first = inits(4, a)
    for u, v in zip(first, random_init(K, 4, 1, 1, b)):  # the first restart: random_init's
        np.testing.assert_array_equal(u, v)
    rest = [inits(4, a) for _ in range(6)]
    assert len(inits._frames) == 1  # one embedding for all of them
    for s, _e, lab in rest:
        np.testing.assert_array_equal(s, np.arange(n))
        assert lab.min() >= 0 and lab.max() < 4
        # a frame's value decides its row of the embedding: equal frames, equal labels
        for v in np.unique(x):
            assert np.unique(lab[x == v]).size == 1
    assert len({lab.tobytes() for _, _, lab in [first, *rest]}) > 1  # k-means seeds differ
