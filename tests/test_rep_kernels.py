"""The repetition counter's numba kernels against their slow twins (tests/naive.py)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import butter, sosfilt

from streamseg._kernels import rep_track as K
from tests.naive import (
    naive_advance,
    naive_dtw_mean,
    naive_edge_dtw,
    naive_pose_features,
    naive_sos_filter,
)


def test_pose_features_match_the_naive_frame_by_frame_version():
    rng = np.random.default_rng(3)
    P = rng.normal(size=(40, 14, 3))
    idx = rng.permutation(14).astype(np.int64)
    up = np.array([0.0, 0.0, 1.0])
    out = np.empty((40, K.N_FEATURES))
    K.pose_features(P, idx, K.BONES, up, 0.4, out)
    np.testing.assert_allclose(out, naive_pose_features(P, idx, K.BONES, up, 0.4), atol=1e-12)
    # every bone direction is a unit vector and the trunk's too
    dirs = out[:, :24].reshape(40, 8, 3)
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=2), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(out[:, 24:27], axis=1), 1.0, atol=1e-12)


def test_a_lost_limb_gives_still_bones_and_leaves_the_rest():
    """A wrist lost in every frame: its forearm's three values are 0, every other value is
    the one of the full pose (nothing NaN), as the naive version says."""
    rng = np.random.default_rng(5)
    P = rng.normal(size=(20, 14, 3))
    idx = np.arange(14, dtype=np.int64)
    up = np.array([0.0, 1.0, 0.0])
    full, lost = np.empty((20, K.N_FEATURES)), np.empty((20, K.N_FEATURES))
    K.pose_features(P, idx, K.BONES, up, 0.4, full)
    Q = P.copy()
    Q[:, K.POINTS.index("l_wrist")] = np.nan
    K.pose_features(Q, idx, K.BONES, up, 0.4, lost)
    np.testing.assert_allclose(lost, naive_pose_features(Q, idx, K.BONES, up, 0.4), atol=1e-12)
    forearm = [b for b, (i, j) in enumerate(K.BONES) if K.POINTS[j] == "l_wrist"]
    cols = np.array([3 * b + c for b in forearm for c in range(3)])
    assert np.isfinite(lost).all() and (lost[:, cols] == 0).all()
    rest = np.setdiff1d(np.arange(K.N_FEATURES), cols)
    np.testing.assert_array_equal(lost[:, rest], full[:, rest])


def test_pose_features_do_not_change_with_heading():
    rng = np.random.default_rng(4)
    P = rng.normal(size=(5, 14, 3))
    a = 1.1  # a turn about the vertical (y) axis
    R = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    idx = np.arange(14, dtype=np.int64)
    up = np.array([0.0, 1.0, 0.0])
    out1, out2 = np.empty((5, 28)), np.empty((5, 28))
    K.pose_features(P, idx, K.BONES, up, 1.0, out1)
    K.pose_features(P @ R.T, idx, K.BONES, up, 1.0, out2)
    np.testing.assert_allclose(out1, out2, atol=1e-12)


def test_sos_filter_matches_scipy_and_the_naive_recursion_in_pieces():
    rng = np.random.default_rng(5)
    X = rng.normal(size=(50, 3))
    sos = butter(2, 3.0, fs=30.0, output="sos")
    state = np.zeros((sos.shape[0], 2, 3))
    out = np.empty_like(X)
    K.sos_filter(X[:20], sos, state, out[:20])
    K.sos_filter(X[20:], sos, state, out[20:])
    np.testing.assert_allclose(out, sosfilt(sos, X, axis=0), atol=1e-12)
    want, _ = naive_sos_filter(X, sos, np.zeros((sos.shape[0], 2, 3)))
    np.testing.assert_allclose(out, want, atol=1e-12)


def _anchor_rows(anchors):
    return [(a["s"], a["tM"], a["tm"], a["M"], a["m"]) for a in anchors]


@pytest.mark.parametrize("search", [True, False])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_advance_matches_the_naive_loop_tracker(search, seed):
    """Loops of a noisy closed path with pauses, in both modes, every call compared."""
    rng = np.random.default_rng(seed)
    n = 400
    t = np.arange(n) / 30.0
    phase = np.cumsum(rng.uniform(0.5, 1.5, n)) / 30.0 * 2 * np.pi / 1.2
    phase[150:190] = phase[150]  # a rest
    Z = np.column_stack([1.5 * np.cos(phase), 1.2 * np.sin(phase), 0.3 * np.sin(2 * t)])
    Z += rng.normal(0, 0.02, Z.shape)
    C = n + 5  # a ring as long as the stream: rows are frames
    SP = np.zeros(C)
    SP[1:n] = np.linalg.norm(np.diff(Z, axis=0), axis=1)
    Zr = np.zeros((C, 3))
    Zr[:n] = Z
    kmax = 6
    st = np.zeros((kmax, 3), dtype=np.int64)
    Mm = np.zeros((kmax, 2))
    na = np.zeros(1, dtype=np.int64)
    closed = np.zeros((kmax, 4))
    na[0] = 1
    Mm[0] = (0.0, np.inf)
    anchors = [dict(s=0, M=0.0, tM=0, m=float("inf"), tm=0)]
    params = dict(
        thr=0.8,
        timeout=90,
        rho=0.55,
        gamma=0.35,
        dabs=0.15,
        eta=0.1,
        pause=30,
        tmax=240,
        gap=6,
        kmax=kmax,
    )
    pos, n_calls = 0, 0
    while pos < n - 1:
        got_t, nc = K.advance(
            Zr,
            SP,
            pos + 1,
            n,
            search,
            st,
            Mm,
            na,
            params["thr"],
            params["timeout"],
            params["rho"],
            params["gamma"],
            params["dabs"],
            params["eta"],
            params["pause"],
            params["tmax"],
            params["gap"],
            params["kmax"],
            closed,
        )
        want_t, want = naive_advance(Z, pos + 1, n, search, anchors, **params)
        assert got_t == want_t
        assert [(int(r[0]), int(r[1]), int(r[2])) for r in closed[:nc]] == [
            (s, k, c) for s, k, c, _ in want
        ]
        np.testing.assert_allclose(closed[:nc, 3], [M for *_, M in want])
        got_anchors = [
            (int(st[i, 0]), int(st[i, 1]), int(st[i, 2]), Mm[i, 0], Mm[i, 1]) for i in range(na[0])
        ]
        assert [a[:3] for a in got_anchors] == [a[:3] for a in _anchor_rows(anchors)]
        n_calls += 1
        pos = got_t
        if nc:  # restart the loop at the first cut, as the counter does
            cut = int(closed[0, 2]) if closed[0, 1] != K.TIMEOUT else got_t
            cut = max(1, min(cut, got_t))
            M, tM, m, tm = K.seed_anchor(Zr, cut, got_t)
            st[0], Mm[0], na[0] = (cut, tM, tm), (M, m), 1
            anchors[:] = [dict(s=cut, M=M, tM=tM, m=m, tm=tm)]
    assert n_calls > 3  # loops closed along the way


def test_seed_anchor_is_the_anchor_after_those_frames():
    rng = np.random.default_rng(7)
    Z = rng.normal(size=(30, 2))
    M, tM, m, tm = K.seed_anchor(Z, 3, 20)
    d = np.linalg.norm(Z[4:21] - Z[3], axis=1)
    assert M == d.max() and tM == 4 + int(np.argmax(d))
    after = d[tM - 3 :]
    assert m == (after.min() if after.size else np.inf) and tm == tM + 1 + int(np.argmin(after))


@pytest.mark.parametrize("shape", [(5, 7), (6, 6), (8, 4)])
def test_dtw_mean_matches_the_recursion(shape):
    rng = np.random.default_rng(shape[0] * 10 + shape[1])
    A, B = rng.normal(size=(shape[0], 3)), rng.normal(size=(shape[1], 3))
    assert K.dtw_mean(A, B) == pytest.approx(naive_dtw_mean(A, B))
    assert K.dtw_mean(A, A) == 0.0


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_edge_dtw_matches_the_written_out_rule(seed):
    rng = np.random.default_rng(seed)
    T, S = rng.normal(size=(6, 2)), rng.normal(size=(11, 2))
    cost, start = K.edge_dtw(T, S)
    want_cost, want_start = naive_edge_dtw(T, S)
    assert cost == pytest.approx(want_cost) and start == want_start


def test_edge_dtw_finds_a_template_inside_a_longer_piece():
    u = np.linspace(0, 2 * np.pi, 20)
    T = np.column_stack([np.sin(u), np.cos(u)])
    S = np.concatenate([np.full((9, 2), [5.0, 5.0]), T])  # unrelated frames, then T
    cost, start = K.edge_dtw(T, S)
    assert cost == pytest.approx(0.0, abs=1e-12) and start == 9
