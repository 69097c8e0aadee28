"""DTAK (eq. 6-7) and frame kernels against the paper's example and the naive recursion."""

from __future__ import annotations

import numpy as np
import pytest

from streamseg._kernels.dtak import dtak_table, segment_kernel, segment_kernel_within
from streamseg.exceptions import ParameterError
from streamseg.offline.dtak import default_sigma, dtak, dtak_matrix, frame_kernel, segment_dtak
from tests.naive import naive_dtak, naive_dtak_p


def test_table1_example_whole_p_matrix():
    # x^ = [1, 2, 1, 2] (rows), x~ = [1, 1, 2, 2] (columns), kappa = 1 iff equal.
    # Derivation, p(i, j) = max(p(i-1, j) + k, p(i-1, j-1) + 2k, p(i, j-1) + k), p(0,0) = 0
    # and every other boundary cell -inf:
    #   row 1 (x^=1): k = 1 1 0 0 -> p11 = 0+2 = 2, p12 = p11+1 = 3, p13 = 3+0, p14 = 3
    #   row 2 (x^=2): k = 0 0 1 1 -> p21 = p11+0 = 2, p22 = max(p12, p11, p21) = 3,
    #                 p23 = max(p13+1, p12+2, p22+1) = 5, p24 = max(p14+1, p13+2, p23+1) = 6
    #   row 3 (x^=1): k = 1 1 0 0 -> p31 = p21+1 = 3, p32 = max(p22+1, p21+2, p31+1) = 4,
    #                 p33 = max(p23, p22, p32) = 5, p34 = max(p24, p23, p33) = 6
    #   row 4 (x^=2): k = 0 0 1 1 -> p41 = 3, p42 = max(p32, p31, p41) = 4,
    #                 p43 = max(p33+1, p32+2, p42+1) = 6, p44 = max(p34+1, p33+2, p43+1) = 7
    expected = np.array([[2, 3, 3, 3], [2, 3, 5, 6], [3, 4, 5, 6], [3, 4, 6, 7]], float)
    P = dtak_matrix([1, 2, 1, 2], [1, 1, 2, 2], kernel="equality")
    np.testing.assert_array_equal(P, expected)
    assert dtak([1, 2, 1, 2], [1, 1, 2, 2], kernel="equality") == 7 / 8


def _random_kernel(rng, n, d=2):
    X = rng.normal(size=(n, d))
    return frame_kernel(X, sigma=1.0)


@pytest.mark.parametrize("seed", range(5))
def test_dtak_table_matches_recursion(seed):
    rng = np.random.default_rng(seed)
    K = _random_kernel(rng, 14)
    a0, a1, b0, b1 = 1, 1 + rng.integers(1, 7), 6, 6 + rng.integers(1, 8)
    P = dtak_table(K, a0, a1, b0, b1)
    ref = naive_dtak_p(K, a0, a1, b0, b1)
    for (i, j), v in ref.items():
        assert P[i, j] == pytest.approx(v, abs=1e-12) or (v == -np.inf and P[i, j] == -np.inf)


def test_segment_kernel_matches_recursion_and_properties():
    rng = np.random.default_rng(7)
    K = _random_kernel(rng, 20)
    starts = np.array([0, 3, 8, 9, 15])
    ends = np.array([3, 8, 9, 15, 20])
    T = segment_kernel(K, starts, ends)
    for i in range(5):
        for j in range(5):
            assert T[i, j] == pytest.approx(
                naive_dtak(K, starts[i], ends[i], starts[j], ends[j]), abs=1e-12
            )
    np.testing.assert_allclose(np.diag(T), 1.0)  # unit diagonal kernel -> self-DTAK is 1
    np.testing.assert_array_equal(T, T.T)
    assert np.all((T >= 0) & (T <= 1 + 1e-12))


def test_segment_kernel_within_keeps_only_same_label_pairs():
    rng = np.random.default_rng(8)
    K = _random_kernel(rng, 20)
    starts = np.array([0, 3, 8, 9, 15])
    ends = np.array([3, 8, 9, 15, 20])
    labels = np.array([0, 1, 0, 1, 1])
    T = segment_kernel_within(K, starts, ends, labels)
    for i in range(5):
        for j in range(5):
            want = (
                naive_dtak(K, starts[i], ends[i], starts[j], ends[j])
                if labels[i] == labels[j]
                else 0.0
            )
            assert T[i, j] == pytest.approx(want, abs=1e-12)


def test_dtak_is_invariant_to_repeating_frames_exactly_with_equality_kernel():
    # a time-stretched copy aligns perfectly: every path cell has kappa = 1
    assert dtak([3, 5, 7], [3, 3, 5, 5, 5, 7], kernel="equality") == 1.0
    assert dtak([3, 5, 7], [4, 6, 8], kernel="equality") == 0.0


def test_frame_kernels():
    X = np.array([[0.0, 0.0], [3.0, 4.0], [0.0, 0.0]])
    K = frame_kernel(X, sigma=5.0)
    assert K[0, 1] == pytest.approx(np.exp(-25 / 50))
    assert K[0, 2] == 1.0 and np.all(np.diag(K) == 1.0)
    E = frame_kernel(X, kernel="equality")
    np.testing.assert_array_equal(E, [[1, 0, 1], [0, 1, 0], [1, 0, 1]])
    with pytest.raises(ParameterError, match="kernel"):
        frame_kernel(X, kernel="laplace")
    with pytest.raises(ParameterError, match="sigma"):
        frame_kernel(X, sigma=0.0)
    with pytest.raises(ParameterError, match="non-finite"):
        frame_kernel(np.array([[0.0], [np.nan]]))


def test_default_sigma_scales_with_data():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(300, 3))
    s = default_sigma(X)
    assert s > 0
    assert default_sigma(10 * X) == pytest.approx(10 * s)


def test_segment_dtak_validates():
    K = np.eye(5)
    with pytest.raises(ParameterError, match="start < end"):
        segment_dtak(K, [(0, 3), (3, 7)])
    T = segment_dtak(K, [(0, 2), (2, 5)])
    assert T.shape == (2, 2)
