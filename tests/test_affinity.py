"""The spectral initialization's normalized affinity (``streamseg._kernels.affinity``) and the
DP step's merging of old segments of identical frames: both the same to the bit as the plain
computation; the embedding of a 0/1 affinity of repeated rows solved on its distinct rows:
the embedding over every item."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg._kernels.affinity import scale_both, symmetrized
from streamseg.offline.aca_descent import _identical_merged, candidate_table, descend, frame_ids
from streamseg.offline.aca_init import (
    _normalized_affinity,
    grouped_embedding,
    propagated_similarity,
    random_tiling,
)
from streamseg.offline.dtak import frame_kernel
from tests.naive import (
    naive_identical_merged,
    naive_normalized_affinity,
    naive_propagated_similarity,
)


def _matrices(m, rng):
    A = rng.random((m, m))
    A[rng.random((m, m)) < 0.3] = 0.0  # some exact zeros, a row of them
    A[m // 2] = 0.0
    B = A > 0.5
    S = B | B.T
    S[m // 3] = False  # a row of zeros left by the symmetric cases too
    S[:, m // 3] = False
    return {
        "float64": A,
        "symmetric": (A + A.T) / 2,
        "bool": B,
        "symmetric bool": S,
        "symmetric int8": S.astype(np.int8),
        "int8": B.astype(np.int8),
    }


@pytest.mark.parametrize("m", [1, 2, 63, 64, 65, 130, 1001])
def test_normalized_affinity_equals_the_numpy_expression(m):
    rng = np.random.default_rng(m)
    for name, A in _matrices(m, rng).items():
        got = _normalized_affinity(A, symmetric=name.startswith("symmetric "))
        want = naive_normalized_affinity(A)
        assert got.dtype == want.dtype == np.float32
        assert np.array_equal(got, want), name


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_kernels_equal_numpy_in_either_dtype(dtype):
    rng = np.random.default_rng(7)
    A = rng.normal(size=(97, 97))
    M = symmetrized(A, np.empty(A.shape, dtype))
    want = np.array(A, dtype=dtype)
    np.fill_diagonal(want, 0.0)
    want += want.T
    want *= 0.5
    assert np.array_equal(M, want)
    s = rng.random(97).astype(dtype)
    scale_both(M, s)
    want *= s[:, None]
    want *= s[None, :]
    assert np.array_equal(M, want)


@pytest.mark.parametrize("seed", range(40))
def test_propagated_similarity_equals_the_numpy_loops(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 90))
    classes = rng.choice([-3, 2, 7, 40][: int(rng.integers(1, 5))], n)  # any class values
    wmax = int(rng.integers(1, 25))
    got = propagated_similarity(classes, wmax)
    assert got.dtype == np.bool_
    assert np.array_equal(got, got.T)  # spectral_labels is told so (propagated_init)
    assert np.array_equal(got, naive_propagated_similarity(classes, wmax))


def _symbols(seed, n=240):
    """A 0/1 equality kernel of a sequence built from repeated motifs (identical segments)."""
    rng = np.random.default_rng(seed)
    motifs = [rng.integers(0, 6, int(rng.integers(5, 9))) for _ in range(3)]
    x = np.concatenate([motifs[int(rng.integers(3))] for _ in range(n // 5)])[:n]
    return frame_kernel(x, kernel="equality")


@pytest.mark.parametrize("seed", range(6))
def test_identical_segments_merged_give_the_same_table(seed):
    K = _symbols(seed).astype(np.int8)
    n = K.shape[0]
    rng = np.random.default_rng(seed)
    starts, ends = random_tiling(n, 5, 8, rng)
    if seed % 2:  # old segments aligned to the motifs repeat exactly
        starts, ends = np.arange(0, n, 6), np.minimum(np.arange(6, n + 6, 6), n)
    labels = rng.integers(0, 3, starts.size).astype(np.int64)
    ids = frame_ids(K)
    assert len(set(ids.tolist())) <= 6
    plain = candidate_table(K, starts, ends, labels, 3, 5, 8, binary=True)
    merged = candidate_table(K, starts, ends, labels, 3, 5, 8, binary=True, frame_ids=ids)
    assert np.array_equal(plain, merged)


@pytest.mark.parametrize("seed", range(6))
def test_descent_with_merged_segments_is_the_same_descent(seed):
    K = _symbols(seed + 10).astype(np.float64)
    n = K.shape[0]
    rng = np.random.default_rng(seed)
    starts, ends = random_tiling(n, 5, 9, rng)
    labels = rng.integers(0, 3, starts.size).astype(np.int64)
    plain = descend(K, starts, ends, labels, 3, 5, 9, 50, binary=True)
    merged = descend(
        K, starts, ends, labels, 3, 5, 9, 50, binary=True, ids=frame_ids(K.astype(np.int8))
    )
    for a, b in zip(plain[:3], merged[:3]):
        assert np.array_equal(a, b)
    assert plain[3] == merged[3] and plain[4] == merged[4]


@pytest.mark.parametrize("seed", range(12))
def test_identical_segments_are_grouped_as_by_their_keys(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 200))
    ids = rng.integers(0, int(rng.integers(1, 4)), n)
    starts, ends = random_tiling(n, 1, int(rng.integers(1, 6)), rng)
    labels = rng.integers(0, 3, starts.size).astype(np.int64)
    order = np.lexsort((labels, starts - ends))  # as candidate_table sorts them
    args = starts[order], ends[order], labels[order], ids
    for got, want in zip(_identical_merged(*args), naive_identical_merged(*args)):
        assert got.dtype == want.dtype and np.array_equal(got, want)


def test_frame_ids_group_identical_rows():
    K = frame_kernel(np.array([3, 1, 3, 2, 1, 3]), kernel="equality")
    assert frame_ids(K).tolist() == [0, 1, 0, 2, 1, 0]


def _dense_embedding(A, k):
    """The k leading eigenvectors of the normalized affinity over every item, unit rows."""
    M = naive_normalized_affinity(A, np.float64)
    _, vecs = np.linalg.eigh(M)
    V = vecs[:, -k:]
    return V / np.linalg.norm(V, axis=1, keepdims=True)


@pytest.mark.parametrize("seed", range(8))
def test_grouped_embedding_is_the_embedding_over_every_item(seed):
    rng = np.random.default_rng(seed)
    g, k = int(rng.integers(6, 14)), int(rng.integers(2, 5))
    B = rng.random((g, g)) < 0.3
    B = B | B.T
    np.fill_diagonal(B, True)
    ids = rng.permutation(np.arange(3 * g) % g)  # every group, three items each, shuffled
    A = B[np.ix_(ids, ids)]
    got = grouped_embedding(A, k)
    if got is None:  # allowed only when the k leading vectors are not group-constant
        w = np.linalg.eigvalsh(naive_normalized_affinity(A, np.float64))
        deg = A.sum(1) - 1
        assert w[-k] <= (-1.0 / deg[deg > 0]).max() + 1e-9
        return
    want = _dense_embedding(A, k)
    # unit rows are unique up to a rotation of the k columns: compare their inner products
    np.testing.assert_allclose(got @ got.T, want @ want.T, atol=1e-8)


def test_grouped_embedding_declines_what_it_does_not_solve():
    rng = np.random.default_rng(3)
    x = rng.integers(0, 5, 60)
    K = x[:, None] == x[None, :]
    assert grouped_embedding(K.astype(np.float64), 2) is None  # not a 0/1 dtype
    assert grouped_embedding(K, 5) is None  # no more groups than k
    A = K.copy()
    A[0, 1:] = True  # row 0 differs from the rest of its group, so its column does too
    assert grouped_embedding(A, 2) is None  # not P B P^T (and not symmetric)
    assert frame_ids(np.eye(8, dtype=np.uint8), 5) is None  # 8 distinct rows, more than 5
