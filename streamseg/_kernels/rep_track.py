"""Kernels of the repetition counter: pose features, causal low-pass, cycle tracking, DTW.

Private: arrays and scalars in and out, no validation (see ``streamseg.online.repetition``).
Every kernel has a slow twin in ``tests/naive.py``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Joint points of :func:`pose_features`, canonical names of ``streamseg.skeleton.names``.
POINTS = (
    "pelvis",
    "sternum",
    "l_hip",
    "r_hip",
    "l_shoulder",
    "l_elbow",
    "l_wrist",
    "r_shoulder",
    "r_elbow",
    "r_wrist",
    "l_knee",
    "l_ankle",
    "r_knee",
    "r_ankle",
)
#: (from, to) rows of :data:`POINTS`: upper arms, forearms, thighs, shins.
BONES = np.array(
    [[4, 5], [5, 6], [7, 8], [8, 9], [2, 10], [10, 11], [3, 12], [12, 13]], dtype=np.int64
)
N_FEATURES = 3 * len(BONES) + 4

#: Kinds of a closed loop (column 1 of :func:`advance`'s output).
CLOSE, PAUSE, TIMEOUT = 1, 2, 3


@njit(cache=True, nogil=True)
def _unit3(v):
    n = np.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if n > 1e-12:
        return v / n
    return v * 0.0


@njit(cache=True, nogil=True)
def pose_features(P, idx, bones, up, scale, out):
    """Heading-free pose of every frame: bone directions in the torso frame and more.

    Parameters
    ----------
    P : ndarray, shape (n, n_joints, 3)
    idx : ndarray of int64, shape (14,)
        Joint index of each of :data:`POINTS`.
    bones : ndarray of int64, shape (8, 2)
        :data:`BONES`.
    up : ndarray, shape (3,)
        World up unit vector.
    scale : float
        Body size (thigh length), for the pelvis height.
    out : ndarray, shape (n, 28)
        Per frame: the 8 bones' unit directions in the torso frame (x from the right hip
        to the left one, y up the trunk, z forward), 24 values (0 for a bone with a lost
        end, so that a limb gone for the whole take leaves the other parts to count); the
        trunk's direction in the heading frame (forward, sideways, up), 3; the pelvis
        height / ``scale``, 1.
    """
    nb = bones.shape[0]
    for f in range(P.shape[0]):
        pel = P[f, idx[0]]
        ax_y = _unit3(P[f, idx[1]] - pel)
        lat = P[f, idx[2]] - P[f, idx[3]]
        lat = lat - (lat[0] * ax_y[0] + lat[1] * ax_y[1] + lat[2] * ax_y[2]) * ax_y
        ax_x = _unit3(lat)
        ax_z = np.cross(ax_x, ax_y)
        for b in range(nb):
            v = P[f, idx[bones[b, 1]]] - P[f, idx[bones[b, 0]]]
            if not (np.isfinite(v[0]) and np.isfinite(v[1]) and np.isfinite(v[2])):
                v[:] = 0.0  # a lost limb: a still bone, not a NaN poisoning every feature
            v = _unit3(v)
            out[f, 3 * b] = v[0] * ax_x[0] + v[1] * ax_x[1] + v[2] * ax_x[2]
            out[f, 3 * b + 1] = v[0] * ax_y[0] + v[1] * ax_y[1] + v[2] * ax_y[2]
            out[f, 3 * b + 2] = v[0] * ax_z[0] + v[1] * ax_z[1] + v[2] * ax_z[2]
        head = ax_z - (ax_z[0] * up[0] + ax_z[1] * up[1] + ax_z[2] * up[2]) * up
        head = _unit3(head)
        side = np.cross(up, head)
        k = 3 * nb
        out[f, k] = ax_y[0] * head[0] + ax_y[1] * head[1] + ax_y[2] * head[2]
        out[f, k + 1] = ax_y[0] * side[0] + ax_y[1] * side[1] + ax_y[2] * side[2]
        out[f, k + 2] = ax_y[0] * up[0] + ax_y[1] * up[1] + ax_y[2] * up[2]
        out[f, k + 3] = (pel[0] * up[0] + pel[1] * up[1] + pel[2] * up[2]) / scale


@njit(cache=True, nogil=True)
def sos_filter(X, sos, state, out):
    """Causal IIR filter of every column (second-order sections, transposed direct form II,
    as ``scipy.signal.sosfilt``), carrying ``state`` from call to call.

    Parameters
    ----------
    X : ndarray, shape (n, d)
    sos : ndarray, shape (n_sections, 6)
    state : ndarray, shape (n_sections, 2, d)
        Updated in place.
    out : ndarray, shape (n, d)
    """
    ns = sos.shape[0]
    for f in range(X.shape[0]):
        for j in range(X.shape[1]):
            x = X[f, j]
            for s in range(ns):
                y = sos[s, 0] * x + state[s, 0, j]
                state[s, 0, j] = sos[s, 1] * x - sos[s, 4] * y + state[s, 1, j]
                state[s, 1, j] = sos[s, 2] * x - sos[s, 5] * y
                x = y
            out[f, j] = x


@njit(cache=True, nogil=True)
def _dist(Z, a, b):
    C = Z.shape[0]
    ra, rb = a % C, b % C
    s = 0.0
    for j in range(Z.shape[1]):
        d = Z[ra, j] - Z[rb, j]
        s += d * d
    return np.sqrt(s)


@njit(cache=True, nogil=True)
def seed_anchor(Z, s, t):
    """(M, tM, m, tm) of an anchor at frame ``s`` after frames ``s + 1 .. t``: the farthest
    distance from its pose, where, and the nearest since then (inf: none yet), where."""
    M, tM, m, tm = 0.0, s, np.inf, s
    for u in range(s + 1, t + 1):
        d = _dist(Z, u, s)
        if d > M:
            M, tM, m = d, u, np.inf
        if u > tM and d < m:
            m, tm = d, u
    return M, tM, m, tm


@njit(cache=True, nogil=True)
def _closes(Z, st, Mm, i, t, thr, rho, gamma, dabs, eta, pause):
    """Update anchor ``i`` with frame ``t``; (kind, cut) when its loop closes, else (0, -1).

    ``st[i]`` = (s, tM, tm), ``Mm[i]`` = (M, m). A loop closes when the pose went at least
    ``thr`` away from the anchor's (M) and came back within ``rho`` M (m): CLOSE once it
    moves away again (rises ``max(dabs, gamma (M - m))`` above m), the cut at the slowest
    frame of the low stretch (within ``eta`` (M - m) of m); PAUSE when the low stretch has
    lasted ``pause`` frames, the cut ``pause // 2`` after it began.
    """
    s = st[i, 0]
    d = _dist(Z, t, s)
    if d > Mm[i, 0]:
        Mm[i, 0] = d
        st[i, 1] = t
        Mm[i, 1] = np.inf
    if t > st[i, 1] and d < Mm[i, 1]:
        Mm[i, 1] = d
        st[i, 2] = t
    M, m, tM, tm = Mm[i, 0], Mm[i, 1], st[i, 1], st[i, 2]
    if M < thr or m > rho * M:
        return 0, -1
    level = m + eta * (M - m)
    rising = d > m + max(dabs, gamma * (M - m))
    if not rising and (d > level or t - tM < pause):
        return 0, -1
    e = tm
    while e - 1 > tM and _dist(Z, e - 1, s) <= level:
        e -= 1
    if not rising:
        if t - e >= pause:
            return PAUSE, e + pause // 2
        return 0, -1
    x = tm
    while x + 1 < t and _dist(Z, x + 1, s) <= level:
        x += 1
    best, cut = np.inf, e
    for u in range(max(tM + 1, e), x + 1):
        v = _dist(Z, u + 1, u - 1)
        if v < best:
            best, cut = v, u
    return CLOSE, cut


@njit(cache=True, nogil=True)
def advance(
    Z,
    SP,
    t0,
    t1,
    search,
    st,
    Mm,
    n_anchors,
    thr,
    timeout,
    rho,
    gamma,
    dabs,
    eta,
    pause,
    tmax,
    gap,
    kmax,
    closed,
):
    """Run the loop tracker over frames ``t0 .. t1 - 1`` until loops close.

    Parameters
    ----------
    Z : ndarray, shape (C, d)
        Ring buffer of the low-passed features (frame t in row t % C).
    SP : ndarray, shape (C,)
        Ring buffer of the speed |Z[t] - Z[t - 1]|.
    t0, t1 : int
    search : bool
        Search mode: an anchor is added at every speed minimum (at least ``gap`` frames
        after the newest), anchors older than ``tmax`` are dropped, at most ``kmax`` kept.
        Otherwise anchor 0 alone is tracked, and frames ``timeout`` after it with no closed
        loop end with a TIMEOUT (unless the pose is back near the anchor's: a rest, which
        ends with a CLOSE or a PAUSE).
    st : ndarray of int64, shape (K, 3)
    Mm : ndarray, shape (K, 2)
        The anchors (see :func:`_closes`); updated in place.
    n_anchors : ndarray of int64, shape (1,)
    closed : ndarray, shape (K, 4)
        Output rows (anchor frame, kind, cut, M) of the loops closed at the returned frame.

    Returns
    -------
    t : int
        Last frame processed (``t1 - 1`` when no loop closed).
    n_closed : int
    """
    K = st.shape[0]
    for t in range(t0, t1):
        n = n_anchors[0]
        if search:
            p = t - 1
            C = SP.shape[0]
            if p >= 1 and SP[p % C] <= SP[(p - 1) % C] and SP[p % C] < SP[t % C]:
                if n == 0 or p - st[n - 1, 0] >= gap:
                    if n == K:  # full: the oldest goes
                        for i in range(1, K):
                            st[i - 1] = st[i]
                            Mm[i - 1] = Mm[i]
                        n -= 1
                    st[n, 0], st[n, 1], st[n, 2] = p, p, p
                    Mm[n, 0], Mm[n, 1] = 0.0, np.inf
                    n += 1
            nc = 0
            keep = 0
            for i in range(n):
                kind, cut = _closes(Z, st, Mm, i, t, thr, rho, gamma, dabs, eta, pause)
                if kind:
                    closed[nc, 0], closed[nc, 1] = st[i, 0], kind
                    closed[nc, 2], closed[nc, 3] = cut, Mm[i, 0]
                    nc += 1
                elif t - st[i, 0] <= tmax:
                    st[keep] = st[i]
                    Mm[keep] = Mm[i]
                    keep += 1
            drop = max(0, keep - kmax)
            if drop:
                for i in range(drop, keep):
                    st[i - drop] = st[i]
                    Mm[i - drop] = Mm[i]
            n_anchors[0] = keep - drop
            if nc:
                return t, nc
        else:
            kind, cut = _closes(Z, st, Mm, 0, t, thr, rho, gamma, dabs, eta, pause)
            if kind:
                closed[0, 0], closed[0, 1], closed[0, 2], closed[0, 3] = (
                    st[0, 0],
                    kind,
                    cut,
                    Mm[0, 0],
                )
                return t, 1
            returned = Mm[0, 0] >= thr and Mm[0, 1] <= rho * Mm[0, 0]
            if t - st[0, 0] > timeout and not returned:  # back at rest: wait for the pause
                closed[0, 0], closed[0, 1], closed[0, 2], closed[0, 3] = (
                    st[0, 0],
                    TIMEOUT,
                    -1,
                    Mm[0, 0],
                )
                return t, 1
    return t1 - 1, 0


@njit(cache=True, nogil=True)
def dtw_mean(A, B):
    """Mean Euclidean frame distance along the cheapest DTW path of ``A`` and ``B``.

    Steps (1, 1), (1, 0), (0, 1), each cell counted once; the cheapest total cost, divided
    by the number of cells on that path (the first such path on ties, diagonal first).

    Parameters
    ----------
    A : ndarray, shape (n, d)
    B : ndarray, shape (m, d)

    Returns
    -------
    float
    """
    n, m = A.shape[0], B.shape[0]
    D = np.full((n + 1, m + 1), np.inf)
    L = np.zeros((n + 1, m + 1), dtype=np.int64)
    D[0, 0] = 0.0
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            c = 0.0
            for k in range(A.shape[1]):
                x = A[i - 1, k] - B[j - 1, k]
                c += x * x
            c = np.sqrt(c)
            best, bl = D[i - 1, j - 1], L[i - 1, j - 1]
            if D[i - 1, j] < best:
                best, bl = D[i - 1, j], L[i - 1, j]
            if D[i, j - 1] < best:
                best, bl = D[i, j - 1], L[i, j - 1]
            D[i, j] = best + c
            L[i, j] = bl + 1
    return D[n, m] / L[n, m]


@njit(cache=True, nogil=True)
def edge_dtw(T, S):
    """Align all of template ``T`` to the piece of ``S`` that ends at its last frame.

    The piece's first frame is free (open begin): row 0 of the template may start on any
    frame of ``S``; afterwards each cell takes, of its three predecessors ((1, 1), (1, 0),
    (0, 1); none left of column 0 nor along row 0), the one that gives the lowest mean
    cost per cell so far. A greedy recursion (the mean is not additive), exact for the
    paths it compares.

    Parameters
    ----------
    T : ndarray, shape (n, d)
    S : ndarray, shape (m, d)

    Returns
    -------
    cost : float
        Mean frame distance along the path ending at (n - 1, m - 1).
    start : int
        Its first frame in ``S``.
    """
    n, m = T.shape[0], S.shape[0]
    D = np.full((n, m), np.inf)
    L = np.zeros((n, m), dtype=np.int64)
    B = np.zeros((n, m), dtype=np.int64)
    for i in range(n):
        for j in range(m):
            c = 0.0
            for k in range(T.shape[1]):
                x = T[i, k] - S[j, k]
                c += x * x
            c = np.sqrt(c)
            if i == 0:
                D[0, j], L[0, j], B[0, j] = c, 1, j
                continue
            best, bs, bl, bb = np.inf, np.inf, 0, 0
            for step in range(3):
                a = i - 1 if step < 2 else i
                b = j - 1 if step != 1 else j
                if b < 0 or (step == 2 and a == 0):
                    continue
                if not np.isfinite(D[a, b]):
                    continue
                v = (D[a, b] + c) / (L[a, b] + 1)
                if v < best:
                    best, bs, bl, bb = v, D[a, b], L[a, b], B[a, b]
            if np.isfinite(best):
                D[i, j], L[i, j], B[i, j] = bs + c, bl + 1, bb
    return D[n - 1, m - 1] / max(L[n - 1, m - 1], 1), B[n - 1, m - 1]
