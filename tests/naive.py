"""Slow, obvious reference implementations: the test twin of every numba kernel.

Nothing here is fast or clever on purpose; each function follows the paper's definition.
"""

from __future__ import annotations

import functools

import numpy as np

# --- skeleton features -------------------------------------------------------------


def naive_bone_angles(positions, points, pairs):
    """Angle between bones ``pairs[a]`` (indices into ``points``, rows (parent, child)) of
    every frame, by the textbook formula acos(u.v / |u||v|); NaN where undefined."""
    import math

    out = np.full((len(positions), len(pairs)), np.nan)
    for f, frame in enumerate(positions):
        for a, (i, j) in enumerate(pairs):
            u = [frame[points[i][1]][d] - frame[points[i][0]][d] for d in range(3)]
            v = [frame[points[j][1]][d] - frame[points[j][0]][d] for d in range(3)]
            nu = math.sqrt(sum(x * x for x in u))
            nv = math.sqrt(sum(x * x for x in v))
            if nu > 0 and nv > 0 and all(math.isfinite(x) for x in u + v):
                c = sum(x * y for x, y in zip(u, v)) / (nu * nv)
                out[f, a] = math.acos(max(-1.0, min(1.0, c)))
    return out


def naive_inclinations(positions, points, up):
    """Angle of every bone (rows (parent, child) of ``points``) from the vector ``up``, per
    frame, by acos(u.up / |u||up|); NaN where undefined."""
    import math

    out = np.full((len(positions), len(points)), np.nan)
    nup = math.sqrt(sum(x * x for x in up))
    for f, frame in enumerate(positions):
        for b, (p, c) in enumerate(points):
            u = [frame[c][d] - frame[p][d] for d in range(3)]
            nu = math.sqrt(sum(x * x for x in u))
            if nu > 0 and all(math.isfinite(x) for x in u):
                cos = sum(x * y for x, y in zip(u, up)) / (nu * nup)
                out[f, b] = math.acos(max(-1.0, min(1.0, cos)))
    return out


def naive_speed_columns(x, lag, speed_max, fps, n_root=0):
    """The features and their angular speeds by the definition (``LOFConfig.speed_max``):
    ``pi * min(|x[t] - x[r]| / (speed_max * lag / fps), 1)`` with ``r`` the latest frame
    without NaN at least ``lag`` frames before ``t``, else the first frame without NaN; NaN
    speeds for a frame with a NaN. With ``n_root`` root-speed columns (the last ones), the
    order is: the other features, their speeds, the root columns, their speeds."""
    import math

    x = np.asarray(x, dtype=float)
    n, d = x.shape
    finite = [all(math.isfinite(v) for v in row) for row in x]
    out = np.full((n, 2 * d), np.nan)
    out[:, :d] = x
    for t in range(n):
        if not finite[t]:
            continue
        earlier = [r for r in range(t - lag + 1) if finite[r]]
        r = earlier[-1] if earlier else min(r for r in range(t + 1) if finite[r])
        for a in range(d):
            change = abs(x[t, a] - x[r, a]) / (speed_max * lag / fps)
            out[t, d + a] = math.pi * min(change, 1.0)
    m = d - n_root
    order = list(range(m)) + list(range(d, d + m)) + list(range(m, d)) + list(range(d + m, 2 * d))
    return out[:, order]


# --- LOF, sliding histograms, peaks ------------------------------------------------


def naive_window_counts(angles, window, step, bins):
    """Per-window, per-angle ``np.histogram`` counts of the frames without NaN.

    Returns counts (m, n_angles * bins) and valid-frame counts (m,) for every complete window
    ``[w * step, w * step + window)``.
    """
    angles = np.asarray(angles, dtype=float)
    n, a = angles.shape
    edges = np.linspace(0.0, np.pi, bins + 1)
    out, nv = [], []
    w = 0
    while w * step + window <= n:
        block = angles[w * step : w * step + window]
        block = block[np.isfinite(block).all(axis=1)]
        row = []
        for j in range(a):
            # np.histogram's last bin is closed, so pi lands in the last bin; clip like the kernel
            h, _ = np.histogram(np.clip(block[:, j], 0.0, np.pi), bins=edges)
            row.extend(h)
        out.append(row)
        nv.append(len(block))
        w += 1
    return np.array(out, dtype=float).reshape(-1, a * bins), np.array(nv, dtype=np.int64)


def naive_cosine_lof(x, k, times=None, exclusion=0):
    """LOF by the definitions, neighbours sorted by (distance, index), scikit-learn's 1e-10.

    Rows whose ``times`` differ by less than ``exclusion`` are not neighbours.
    """
    x = np.asarray(x, dtype=float)
    n = len(x)
    times = np.arange(n) if times is None else np.asarray(times)
    nrm = (x * x).sum(axis=1)
    d = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            den = np.sqrt(nrm[i] * nrm[j])
            d[i, j] = 1.0 if den == 0 else max(0.0, 1.0 - float(x[i] @ x[j]) / den)
    kk = k if exclusion > 0 else min(k, n - 1)
    nbrs = []
    for i in range(n):
        cand = [j for j in range(n) if j != i and abs(times[i] - times[j]) >= exclusion]
        cand.sort(key=lambda j: (d[i, j], j))
        nbrs.append(cand[:kk])
    kdist = np.array([d[i, nb[-1]] if nb else 0.0 for i, nb in enumerate(nbrs)])
    lrd = np.array(
        [
            1.0 / (np.mean([max(d[i, o], kdist[o]) for o in nb]) + 1e-10) if nb else 1e10
            for i, nb in enumerate(nbrs)
        ]
    )
    return np.array(
        [np.mean([lrd[o] / lrd[i] for o in nb]) if nb else 1.0 for i, nb in enumerate(nbrs)]
    )


def naive_douglas_peucker(y, eps):
    """Indices kept by recursive Douglas-Peucker on (i, y[i]) with vertical deviation."""
    y = np.asarray(y, dtype=float)

    def rec(a, b):
        if b - a < 2:
            return []
        i = np.arange(a + 1, b)
        dev = np.abs(y[i] - (y[a] + (y[b] - y[a]) / (b - a) * (i - a)))
        at = int(i[np.argmax(dev)])
        if dev.max() <= eps:
            return []
        return rec(a, at) + [at] + rec(at, b)

    return [0] + rec(0, len(y) - 1) + [len(y) - 1]


def naive_peak_windows(y, delay, tol, n_mads, min_score, min_gap):
    """The peak rule written out: local DP peak, highest within the gap, robust threshold,
    first-wins min gap."""
    y = np.asarray(y, dtype=float)
    med = np.median(y)
    thr = max(min_score, med + n_mads * 1.4826 * np.median(np.abs(y - med)))
    out = []
    for w in range(len(y)):
        if y[w] < thr or (out and w - out[-1] < min_gap):
            continue
        lo, hi = max(0, w - delay), min(len(y) - 1, w + delay)
        seg = y[lo : hi + 1]
        if w in (lo, hi) or seg.max() <= seg.min():
            continue
        if y[max(lo, w - min_gap) : min(hi, w + min_gap) + 1].max() > y[w]:
            continue  # a higher value within the gap wins
        keep = naive_douglas_peucker(seg, tol * (seg.max() - seg.min()))
        c = w - lo
        if c not in keep:
            continue
        pos = keep.index(c)
        if seg[keep[pos - 1]] < seg[c] and seg[keep[pos + 1]] < seg[c]:
            out.append(w)
    return out


def naive_refine_cut(angles, bins, centre, radius, window, n_avail, first=0):
    """Frame in ``centre +- radius`` (and ``>= first``) maximizing ``1 - cos`` between the
    per-angle histogram counts of the ``window`` frames before and after it (frames without
    NaN, frames before ``n_avail`` only); the earliest maximum, or ``centre`` when no frame
    qualifies."""
    angles = np.asarray(angles, dtype=float)
    lo = max(centre - radius, window, first)
    hi = min(centre + radius, n_avail - window)
    if hi < lo:
        return centre

    def hist(block):
        return naive_window_counts(block, len(block), 1, bins)[0][0]

    best, at = -1.0, centre
    for g in range(lo, hi + 1):
        a, b = hist(angles[g - window : g]), hist(angles[g : g + window])
        den = np.sqrt(float(a @ a) * float(b @ b))
        dist = 1.0 if den == 0 else 1.0 - float(a @ b) / den
        if dist > best:
            best, at = dist, g
    return at


def _sides_distance(left, right, bins):
    """``1 - cos`` between the per-angle histogram counts of two blocks of frames (frames
    without NaN only); -1 when a block has no valid frame."""

    def hist(block):
        block = block[np.isfinite(block).all(axis=1)]
        if len(block) == 0:
            return None
        return naive_window_counts(block, len(block), 1, bins)[0][0]

    a, b = hist(left), hist(right)
    if a is None or b is None:
        return -1.0
    return max(0.0, 1.0 - float(a @ b) / np.sqrt(float(a @ a) * float(b @ b)))


def naive_contrast(angles, bins, g, window, n_avail, oldest=0):
    """``1 - cos`` between the per-angle histogram counts of the frames ``[g - window, g)``
    and ``[g, g + window)``, each clipped to ``[oldest, n_avail)`` (frames without NaN only);
    -1 when a side has no valid frame."""
    angles = np.asarray(angles, dtype=float)
    return _sides_distance(
        angles[max(oldest, g - window) : min(g, n_avail)],
        angles[max(oldest, g) : min(g + window, n_avail)],
        bins,
    )


def naive_span_contrast(angles, bins, lo, g, hi):
    """``1 - cos`` between the per-angle histogram counts of the frames ``[lo, g)`` and
    ``[g, hi)`` (frames without NaN only); -1 when a side has no valid frame."""
    angles = np.asarray(angles, dtype=float)
    return _sides_distance(angles[lo:g], angles[g:hi], bins)


def naive_sorted_neighbours(x, times=None, exclusion=0):
    """Every row's eligible neighbours (itself and rows closer than ``exclusion`` in time
    excluded) as ``(distance, index)`` pairs sorted by distance then index."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    times = np.arange(n) if times is None else np.asarray(times)
    nrm = (x * x).sum(axis=1)
    out = []
    for i in range(n):
        row = []
        for j in range(n):
            if j == i or abs(times[i] - times[j]) < exclusion:
                continue
            den = np.sqrt(nrm[i] * nrm[j])
            row.append((1.0 if den == 0 else max(0.0, 1.0 - float(x[i] @ x[j]) / den), j))
        out.append(sorted(row))
    return out


def naive_robust_threshold(y, n_mads):
    """``median + n_mads * 1.4826 * MAD`` read off fully sorted copies (NaN sorts last)."""

    def med(v):
        w = np.sort(np.asarray(v, dtype=float))
        n = len(w)
        return w[n // 2] if n % 2 else 0.5 * (w[n // 2 - 1] + w[n // 2])

    m = med(y)
    return m + n_mads * 1.4826 * med(np.abs(np.asarray(y, dtype=float) - m))


# --- ACA: DTAK, DP segmentation, kernel k-means ------------------------------------


def naive_dtak_p(K, a0, a1, b0, b1):
    """P of eq. 7 by the literal recursion (memoized); returns dict (i, j) -> p_{i,j}."""
    memo = {}

    def p(i, j):
        if i == 0 and j == 0:
            return 0.0
        if i == 0 or j == 0:
            return float("-inf")
        if (i, j) not in memo:
            k = K[a0 + i - 1, b0 + j - 1]
            memo[(i, j)] = max(p(i - 1, j) + k, p(i - 1, j - 1) + 2 * k, p(i, j - 1) + k)
        return memo[(i, j)]

    return {(i, j): p(i, j) for i in range(a1 - a0 + 1) for j in range(b1 - b0 + 1)}


def naive_dtak(K, a0, a1, b0, b1):
    """DTAK of eq. 6 between frame ranges [a0, a1) and [b0, b1) of kernel K."""
    na, nb = a1 - a0, b1 - b0
    return naive_dtak_p(K, a0, a1, b0, b1)[(na, nb)] / (na + nb)


def naive_normalized_affinity(A, dtype=np.float32):
    """``D^-1/2 S D^-1/2`` of ``S = (A + A.T) / 2`` with a zero diagonal, in ``dtype``, as
    the spectral initialization built it with numpy before ``streamseg._kernels.affinity``."""
    M = np.array(A, dtype=dtype)
    np.fill_diagonal(M, 0.0)
    M += M.T  # numpy buffers the overlapping transpose
    M *= 0.5
    deg = M.sum(1, dtype=np.float64)
    inv = np.where(deg > 0, 1.0 / np.sqrt(np.where(deg > 0, deg, 1.0)), 0.0)
    M *= inv[:, None].astype(M.dtype)
    M *= inv[None, :].astype(M.dtype)
    return M


def naive_propagated_similarity(frame_classes, wmax):
    """Eq. 10 as numpy loops over the lag ``d`` (``streamseg._kernels.affinity.propagated``).

    ``kappa[i, j] = 1`` for frames of one class; then for every pair ``(i1, i2)`` of the same
    class whose frames ``d`` steps earlier (``1 <= d <= wmax``) also share a class, the
    pairs ``(i1, i1-d)``, ``(i2, i2-d)``, ``(i1, i2-d)``, ``(i1-d, i2)`` become 1 (both orders).
    """
    c = np.asarray(frame_classes)
    n = c.shape[0]
    S = c[:, None] == c[None, :]
    out = S.copy()
    idx = np.arange(n)
    for d in range(1, min(wmax, n - 1) + 1):
        M = S[d:, d:] & S[:-d, :-d]  # M[a, b]: i1 = a + d, i2 = b + d
        out[d:, :-d] |= M  # (i1, i2 - d)
        out[:-d, d:] |= M  # (i1 - d, i2)
        has = M.any(axis=1)  # i1 (and i1 itself as i2) matched: link (i1, i1 - d)
        ii = idx[d:][has]
        out[ii, ii - d] = True
    out |= out.T
    return out


def naive_dist(K, seg, old_segs, old_labels, c):
    """dist_c of eq. 3 for segment ``seg`` = (s, e) against the centre of cluster c."""
    members = [sg for sg, lab in zip(old_segs, old_labels) if lab == c]
    nc = len(members)
    self_k = naive_dtak(K, seg[0], seg[1], seg[0], seg[1])
    f = sum(naive_dtak(K, seg[0], seg[1], s, e) for s, e in members)
    h = sum(naive_dtak(K, s1, e1, s2, e2) for s1, e1 in members for s2, e2 in members)
    return self_k - 2 * f / nc + h / nc**2


def all_tilings(n, wmin, wmax):
    """Every list of (start, end) covering 0..n with lengths in [wmin, wmax]."""
    if n == 0:
        return [[]]
    out = []
    for w in range(wmin, min(wmax, n) + 1):
        for rest in all_tilings(n - w, wmin, wmax):
            out.append([(0, w)] + [(s + w, e + w) for s, e in rest])
    return out


def naive_dp(K, old_segs, old_labels, k, wmin, wmax):
    """Brute force over all tilings: min over segmentations of sum of min_c dist_c."""
    used = sorted(set(old_labels))
    best = float("inf")
    for tiling in all_tilings(K.shape[0], wmin, wmax):
        cost = sum(min(naive_dist(K, seg, old_segs, old_labels, c) for c in used) for seg in tiling)
        best = min(best, cost)
    return best


def naive_forward_dp(K, old_segs, old_labels, k, wmin, wmax):
    """Eq. 9 by its forward recursion with every candidate's distances computed directly;
    returns (cost, [(start, end, label), ...]) (the first best on ties, as the kernel)."""
    n = K.shape[0]
    used = [c for c in range(k) if c in set(old_labels)]
    L = [0.0] + [float("inf")] * n
    back = [None] * (n + 1)
    for v in range(1, n + 1):
        for w in range(wmin, min(wmax, v) + 1):
            if L[v - w] == float("inf"):
                continue
            d, c = min((naive_dist(K, (v - w, v), old_segs, old_labels, c), c) for c in used)
            if L[v - w] + d < L[v]:
                L[v], back[v] = L[v - w] + d, (v - w, c)
    segs, v = [], n
    while v > 0 and back[v] is not None:
        segs.append((back[v][0], v, back[v][1]))
        v = back[v][0]
    return L[n], segs[::-1]


def naive_objective(K, segs, labels):
    """Eq. 5 for segmentation ``segs`` with ``labels`` (centres from the segmentation itself)."""
    return sum(naive_dist(K, seg, segs, labels, c) for seg, c in zip(segs, labels))


def naive_kernel_kmeans(K, labels, k, max_iter=100):
    """Kernel k-means (eq. 2-4) by Lloyd steps from ``labels``; an empty cluster takes the point
    farthest from its own centre among clusters with >= 2 points. Returns final labels."""
    labels = np.array(labels)
    n = K.shape[0]

    def dists(lab):
        D = np.full((n, k), np.inf)
        for c in range(k):
            idx = np.flatnonzero(lab == c)
            if idx.size:
                D[:, c] = (
                    np.diag(K)
                    - 2 * K[:, idx].sum(1) / idx.size
                    + K[np.ix_(idx, idx)].sum() / idx.size**2
                )
        return D

    def reseed(lab):
        while True:
            counts = np.bincount(lab, minlength=k)
            empty = np.flatnonzero(counts == 0)
            movable = counts[lab] >= 2
            if empty.size == 0 or not movable.any():
                return lab
            own = dists(lab)[np.arange(n), lab]
            own[~movable] = -np.inf
            lab = lab.copy()
            lab[int(np.argmax(own))] = empty[0]

    for _ in range(max_iter):
        labels = reseed(labels)
        new = np.argmin(dists(labels), axis=1)
        if np.array_equal(new, labels):
            break
        labels = new
    return reseed(labels)


def naive_lloyd(X, centres, n_iter):
    """Lloyd's k-means from ``centres`` (copied), written plainly: nearest centre by squared
    distance (first on ties), an empty cluster (index order) takes the point farthest from its
    centre, stop when labels repeat. Returns ``(labels, centres)``."""
    X = np.asarray(X, dtype=np.float64)
    centres = np.array(centres, dtype=np.float64)
    n, k = X.shape[0], centres.shape[0]
    labels = np.full(n, -1)
    for _ in range(n_iter):
        dist = np.array(
            [[float(np.sum((X[i] - centres[c]) ** 2)) for c in range(k)] for i in range(n)]
        )
        new = np.argmin(dist, axis=1)
        for c in range(k):
            if not np.any(new == c):
                far = int(np.argmax(dist[np.arange(n), new]))
                new[far] = c
                dist[far, :] = 0.0
        if np.array_equal(new, labels):
            break
        labels = new
        for c in range(k):
            if np.any(labels == c):  # an empty cluster keeps its centre
                centres[c] = X[labels == c].mean(0)
    return labels, centres


def naive_settle(pending, finals, g, n_frames, onset=False):
    """The two-stage detector's live events (``streamseg.daemon.cut_events.cut_kind`` kinds)
    rebuilt from its pending cuts and the one-stage detector's cuts at the confirming delay,
    each ``(frame, score, emitted_at)`` (no NaN frames: window ``s`` completes on frame
    ``s * step + window - 1``), by the rule of ``LOFConfig.early_delay_s``: when the final
    stage decides window ``w``, its cut confirms (same frame) or moves (another frame) the
    oldest pending cut whose window is within ``min_gap`` of ``w``, else it is a plain cut;
    then every pending cut whose window + ``min_gap`` <= ``w`` is withdrawn; then the early
    stage's cut of window ``s - early`` is pending. With ``onset`` (``LOFConfig.onset_mads``)
    a pending cut emitted on window ``s`` counts as window ``s + onset_lead``. Returns
    ``(kind, frame, emitted_at)``."""
    win, step, delay, early, tol = (g["window"], g["step"], g["delay"], g["early"], g["min_gap"])

    def seq_of(f):
        assert (f - (win - 1)) % step == 0
        return (f - (win - 1)) // step

    final = {seq_of(e) - delay: f for f, _, e in finals}
    shift = g["onset_lead"] if onset else -early
    pend = {seq_of(e): (seq_of(e) + shift, f) for f, _, e in pending}
    out, open_ = [], []
    for s in range((n_frames - win) // step + 1):
        at, w = s * step + win - 1, s - delay
        if w in final:
            c = final[w]
            match = [p for p in open_ if abs(p[0] - w) <= tol]
            if not match:
                out.append(("cut", c, at))
            else:
                open_.remove(match[0])
                out += (
                    [("confirm", c, at)]
                    if match[0][1] == c
                    else [("moved", match[0][1], at), ("cut", c, at)]
                )
        for p in [p for p in open_ if p[0] + tol <= w]:
            open_.remove(p)
            out.append(("withdraw", p[1], at))
        if s in pend:
            open_.append(pend[s])
            out.append(("pending", pend[s][1], at))
    return out


def naive_onset(snapshots, finals, cfg, g):
    """The onset rule (``LOFConfig.onset_mads``) replayed on the LOF curves: ``snapshots``
    holds, after each window ``s`` was inserted, ``(s, frames seen, curve, centres)`` (the
    buffered windows' LOF values and centre frames, oldest first), ``finals`` the one-stage
    cuts ``(frame, score, emitted_at)`` (no NaN frames). A pending cut on window ``s`` when
    its LOF is at least ``min_score``, rose in each of the last ``onset_rises`` windows
    (strictly) and reaches the median + ``onset_mads`` * 1.4826 * MAD of the curve, at least
    ``early`` windows after the last onset and after the last final cut's window, its window
    ``s + onset_lead`` at least ``min_gap`` after that cut's; placed at the centre of ``s`` +
    ``onset_lead`` windows, at most the last frame seen and at least ``min_gap`` windows of
    frames after the last final cut. Returns ``(frame, score, emitted_at)``."""
    win, step, delay, gap, lead = g["window"], g["step"], g["delay"], g["early"], g["onset_lead"]
    decided = [((e - (win - 1)) // step, f) for f, _, e in finals]
    by_decision = {s: (f, s - delay) for s, f in decided}
    none = -(1 << 40)
    last_onset, last_w, last_f = none, none, none
    out = []
    for s, seen, curve, centres in snapshots:
        if s in by_decision:  # the final stage decides first
            last_f, last_w = by_decision[s]
        r = cfg.onset_rises
        if len(curve) < r + 1:
            continue
        if s - max(last_onset, last_w) < gap or s + lead - last_w < g["min_gap"]:
            continue
        y = curve[-1]
        if y < cfg.min_score or any(curve[-1 - j] <= curve[-2 - j] for j in range(r)):
            continue
        if y < naive_robust_threshold(curve, cfg.onset_mads):
            continue
        c = min(int(centres[-1]) + lead * step, seen - 1)
        c = max(c, last_f + g["min_gap"] * step)
        if c >= seen:
            continue
        last_onset = s
        out.append((c, float(y), s * step + win - 1))
    return out


def naive_root_speeds(pos, root, limbs, up, fps, lag, v_max, jump):
    """The root-speed columns by the definition (``LOFConfig.root_speed_max``), frame by frame:
    step ``t`` = (root[t] - root[t-1]) / (mean limb length at t) (frame 0: 0), a step longer
    than ``jump`` body scales per frame counts as 0, speed = the sum of the last ``lag`` steps
    (fewer at the start) x fps / lag, split along ``up`` into horizontal and vertical,
    ``pi * min(speed / v_max, 1)``; NaN while a NaN step is among the last ``lag``."""
    import math

    pos = np.asarray(pos, dtype=float)
    n = pos.shape[0]
    steps = []
    for t in range(n):
        scale = sum(math.dist(pos[t, b], pos[t, a]) for a, b in limbs) / len(limbs)
        if t == 0:
            ok = all(math.isfinite(v) for v in pos[0, root]) and scale > 0
            step = [0.0] * 3 if ok else [math.nan] * 3
        else:
            step = [
                (pos[t, root, a] - pos[t - 1, root, a]) / scale if scale > 0 else math.nan
                for a in range(3)
            ]
        if math.sqrt(sum(v * v for v in step)) > jump:
            step = [0.0] * 3
        steps.append(step)
    out = np.zeros((n, 2))
    for t in range(n):
        moved = [sum(steps[r][a] for r in range(max(0, t - lag + 1), t + 1)) for a in range(3)]
        vert = sum(moved[a] * up[a] for a in range(3))
        hor = math.sqrt(sum((moved[a] - vert * up[a]) ** 2 for a in range(3)))
        speed = (hor * fps / lag, abs(vert) * fps / lag)
        out[t] = [math.nan if math.isnan(v) else math.pi * min(v / v_max, 1.0) for v in speed]
    return out


def naive_lof_columns(pos, points, up, fps, lag, speed_max, root=None):
    """The live detector's columns of joint positions by the definitions, for
    ``streamseg._kernels.stream_features.lof_columns``: the 8 bone angles, the 9 inclinations
    from ``up`` (None: none), the 2 root speeds when ``root = (joint, limbs, v_max, jump)``,
    then the angular speeds of every column (``speed_max > 0``) in the detector's order."""
    from streamseg.skeleton.bones import ANGLES

    feats = naive_bone_angles(pos, points, ANGLES)
    if up is not None:
        feats = np.column_stack([feats, naive_inclinations(pos, points, up)])
    n_root = 0
    if root is not None:
        joint, limbs, v_max, jump = root
        up_ = np.zeros(3) if up is None else np.asarray(up, dtype=float)
        feats = np.column_stack(
            [feats, naive_root_speeds(pos, joint, limbs, up_, fps, lag, v_max, jump)]
        )
        n_root = 2
    if speed_max <= 0:
        return feats
    return naive_speed_columns(feats, lag, speed_max, fps, n_root)


# --- repetitions: pose features, causal filter, loop tracking, DTW ---------------------------


def naive_pose_features(P, idx, bones, up, scale):
    """``streamseg._kernels.rep_track.pose_features`` frame by frame with numpy's vector
    operations: the torso frame (x right hip -> left hip made orthogonal to y, y pelvis ->
    sternum, z = x cross y), each bone's unit direction in it, the trunk in the heading frame,
    the pelvis height / scale."""

    def unit(v):
        n = float(np.linalg.norm(v))
        return v / n if n > 1e-12 else v * 0.0

    out = []
    for fr in np.asarray(P, dtype=np.float64):
        pel = fr[idx[0]]
        y = unit(fr[idx[1]] - pel)
        lat = fr[idx[2]] - fr[idx[3]]
        x = unit(lat - np.dot(lat, y) * y)
        z = np.cross(x, y)
        row = []
        for a, b in bones:
            v = fr[idx[b]] - fr[idx[a]]
            v = unit(v) if np.isfinite(v).all() else np.zeros(3)  # a lost limb: 0
            row += [np.dot(v, x), np.dot(v, y), np.dot(v, z)]
        head = unit(z - np.dot(z, up) * up)
        side = np.cross(up, head)
        row += [np.dot(y, head), np.dot(y, side), np.dot(y, up), np.dot(pel, up) / scale]
        out.append(row)
    return np.array(out)


def naive_sos_filter(X, sos, state):
    """Second-order sections applied sample by sample by their difference equations
    (transposed direct form II), state carried; returns (output, final state)."""
    state = np.array(state, dtype=np.float64)
    out = np.zeros_like(np.asarray(X, dtype=np.float64))
    for f, row in enumerate(np.asarray(X, dtype=np.float64)):
        for j, x in enumerate(row):
            for s, (b0, b1, b2, _a0, a1, a2) in enumerate(sos):
                y = b0 * x + state[s, 0, j]
                state[s, 0, j] = b1 * x - a1 * y + state[s, 1, j]
                state[s, 1, j] = b2 * x - a2 * y
                x = y
            out[f, j] = x
    return out, state


def naive_loop_step(Z, anchor, t, thr, rho, gamma, dabs, eta, pause):
    """One frame of one anchor of ``rep_track._closes`` on full arrays: ``anchor`` a dict
    (s, M, tM, m, tm) updated in place; returns (kind, cut), kind 0 for no closed loop."""
    s = anchor["s"]

    def d(u):
        return float(np.linalg.norm(Z[u] - Z[s]))

    du = d(t)
    if du > anchor["M"]:
        anchor.update(M=du, tM=t, m=float("inf"))
    if t > anchor["tM"] and du < anchor["m"]:
        anchor.update(m=du, tm=t)
    M, m, tM, tm = anchor["M"], anchor["m"], anchor["tM"], anchor["tm"]
    if not (M >= thr and m <= rho * M):
        return 0, -1
    level = m + eta * (M - m)
    e = tm
    while e - 1 > tM and d(e - 1) <= level:
        e -= 1
    if du > m + max(dabs, gamma * (M - m)):
        x = tm
        while x + 1 < t and d(x + 1) <= level:
            x += 1
        speeds = {u: float(np.linalg.norm(Z[u + 1] - Z[u - 1])) for u in range(e, x + 1)}
        return 1, min(speeds, key=lambda u: (speeds[u], u))
    if t - e >= pause and du <= level:
        return 2, e + pause // 2
    return 0, -1


def naive_advance(
    Z, t0, t1, search, anchors, thr, timeout, rho, gamma, dabs, eta, pause, tmax, gap, kmax
):
    """``rep_track.advance`` on full arrays (no ring): ``anchors`` a list of dicts, changed
    in place; returns (last frame, [(s, kind, cut, M), ...])."""
    sp = [0.0] + [float(np.linalg.norm(Z[u] - Z[u - 1])) for u in range(1, len(Z))]
    for t in range(t0, t1):
        if search:
            p = t - 1
            if p >= 1 and sp[p] <= sp[p - 1] and sp[p] < sp[t]:
                if not anchors or p - anchors[-1]["s"] >= gap:
                    if len(anchors) == kmax:  # as many rows as the kernel: the oldest goes
                        anchors.pop(0)
                    anchors.append(dict(s=p, M=0.0, tM=p, m=float("inf"), tm=p))
            closed, keep = [], []
            for a in anchors:
                kind, cut = naive_loop_step(Z, a, t, thr, rho, gamma, dabs, eta, pause)
                if kind:
                    closed.append((a["s"], kind, cut, a["M"]))
                elif t - a["s"] <= tmax:
                    keep.append(a)
            anchors[:] = keep[-kmax:]
            if closed:
                return t, closed
        else:
            a = anchors[0]
            kind, cut = naive_loop_step(Z, a, t, thr, rho, gamma, dabs, eta, pause)
            if kind:
                return t, [(a["s"], kind, cut, a["M"])]
            if t - a["s"] > timeout and not (a["M"] >= thr and a["m"] <= rho * a["M"]):
                return t, [(a["s"], 3, -1, a["M"])]
    return t1 - 1, []


def naive_dtw_mean(A, B):
    """Mean frame distance along the cheapest monotone path (steps (1,1), (1,0), (0,1)) from
    (0, 0) to (n-1, m-1), by recursion over all predecessors: (total, cells) per cell."""

    def c(i, j):
        return float(np.linalg.norm(A[i] - B[j]))

    @functools.cache
    def best(i, j):
        if i == 0 and j == 0:
            return c(0, 0), 1
        cands = [
            best(a, b) for a, b in ((i - 1, j - 1), (i - 1, j), (i, j - 1)) if a >= 0 and b >= 0
        ]
        tot, n = min(cands, key=lambda x: x[0])
        return tot + c(i, j), n + 1

    tot, n = best(len(A) - 1, len(B) - 1)
    return tot / n


def naive_edge_dtw(T, S):
    """``rep_track.edge_dtw`` written out: row 0 of ``T`` may start on any frame of ``S``;
    every later cell keeps, of its predecessors (i-1, j-1), (i-1, j), (i, j-1) (not left of
    column 0, not along row 0), the one with the lowest mean cost per cell after adding the
    cell (the first on ties, in that order); returns (mean cost at the last cell, start)."""
    n, m = len(T), len(S)
    cell = {}
    for i in range(n):
        for j in range(m):
            c = float(np.linalg.norm(T[i] - S[j]))
            if i == 0:
                cell[i, j] = (c, 1, j)
                continue
            options = []
            for a, b in ((i - 1, j - 1), (i - 1, j), (i, j - 1)):
                if b < 0 or (a, b) not in cell or (a == i and a == 0):
                    continue
                tot, k, st = cell[a, b]
                options.append(((tot + c) / (k + 1), tot + c, k + 1, st))
            if options:
                mean, tot, k, st = min(options, key=lambda o: o[0])
                cell[i, j] = (tot, k, st)
    tot, k, st = cell[n - 1, m - 1]
    return tot / k, st


# --- lost joints bridged for the repetition counter ---------------------------------


def naive_pose_bridge(P, hold, needed):
    """The bridge's rule over a whole take, frame by frame (streamseg.online.rep_bridge):
    frames before the first with every ``needed`` joint are its copies; then each joint's run
    of lost frames [a, b) of at most ``hold`` frames that ends before the take does is
    interpolated (from the frame it is seen again when never seen before), a longer or
    unended one holds the last value seen (NaN when none). None: no frame has the needed."""
    P = np.array(P, dtype=np.float64)
    n, J = P.shape[:2]
    ok = [all(np.isfinite(P[f, j]).all() for j in needed) for f in range(n)]
    if not any(ok):
        return None
    k = ok.index(True)
    for f in range(k):
        P[f] = P[k]
    out = P.copy()
    for j in range(J):
        f = 0
        while f < n:
            if np.isfinite(P[f, j]).all():
                f += 1
                continue
            a = f
            while f < n and not np.isfinite(P[f, j]).all():
                f += 1
            b = f
            before = P[a - 1, j] if a > 0 else np.full(3, np.nan)
            for i in range(a, b):
                if b < n and b - a <= hold:
                    if np.isfinite(before).all():
                        out[i, j] = before + (i - a + 1) / (b - a + 1) * (P[b, j] - before)
                    else:
                        out[i, j] = P[b, j]
                else:
                    out[i, j] = before
    return out


def naive_random_tiling(n, wmin, wmax, rng):
    """Random tiling of ``0..n`` one length at a time (``streamseg.offline.aca_init``)."""
    bounds, pos = [0], 0
    while n - pos > wmax:
        rest = n - pos
        hi = min(wmax, rest - wmin)
        pos += int(rng.integers(wmin, hi + 1)) if hi >= wmin else min(wmax, rest - 1)
        bounds.append(pos)
    bounds.append(n)
    b = np.asarray(bounds, dtype=np.int64)
    return b[:-1], b[1:]


def naive_identical_merged(starts, ends, labels, frame_ids):
    """``streamseg.offline.aca_descent._identical_merged`` as a dictionary of segment keys."""
    keep, counts, first = [], [], {}
    ids = np.asarray(frame_ids)
    for j, (s, e, lab) in enumerate(zip(starts.tolist(), ends.tolist(), labels.tolist())):
        key = (e - s, lab, ids[s:e].tobytes())
        at = first.get(key)
        if at is None:
            first[key] = len(keep)
            keep.append(j)
            counts.append(1)
        else:
            counts[at] += 1
    keep = np.asarray(keep, dtype=np.int64)
    return starts[keep], ends[keep], labels[keep], np.asarray(counts, dtype=np.int64)


# --- AMC reading ------------------------------------------------------------------


def naive_amc_values(body: bytes, layout):
    """The frames of an AMC body by ``str.split`` and ``float``: ``(n_frames, n_values)``,
    or None unless every frame is its number then each ``(bone, n)`` of ``layout`` with n
    numbers, the numbers counting up by one."""
    tokens = body.decode("latin-1").split()
    width = 1 + sum(1 + n for _, n in layout)
    if not tokens or len(tokens) % width:
        return None
    rows, previous = [], None
    for f in range(len(tokens) // width):
        frame = tokens[f * width : (f + 1) * width]
        try:
            number = int(frame[0])
        except ValueError:
            return None
        if previous is not None and number != previous + 1:
            return None
        previous, row, pos = number, [], 1
        for name, n in layout:
            if frame[pos] != name:
                return None
            try:
                row += [float(w) for w in frame[pos + 1 : pos + 1 + n]]
            except ValueError:
                return None
            pos += 1 + n
        rows.append(row)
    return np.array(rows, dtype=float).reshape(len(rows), width - 1 - len(layout))


def naive_acclaim_pose(skel, layout, values, unit):
    """Acclaim forward kinematics with numpy matrix products, bone by bone:
    ``R = R_parent @ C @ M @ C.T`` (``M`` the dof rotations, first listed applied first),
    end point = parent's end point + ``R @ (direction * length)``; the root at its ASF
    position plus its translations (inches / length scale, as metres)."""
    from streamseg.skeleton.rotations import euler_to_matrix

    n = values.shape[0]
    to_rad = np.pi / 180.0 if unit == "deg" else 1.0
    channels, col = {}, 0
    for name, width in layout:
        channels[name] = values[:, col : col + width]
        col += width
    positions = np.zeros((n, len(skel.bones), 3))
    rotations = np.zeros((n, len(skel.bones), 3, 3))
    for i, bone in enumerate(skel.bones):
        vals = channels.get(bone.name)
        axes, angles, trans = "", [], np.zeros((n, 3))
        for c, dof in enumerate(bone.dof if vals is not None else ()):
            if dof[0] == "r":
                axes += dof[1]
                angles.append(vals[:, c] * to_rad)
            elif dof[0] == "t":
                trans[:, "xyz".index(dof[1])] = vals[:, c] / skel.length_scale * 0.0254
        m = euler_to_matrix(np.stack(angles, axis=1), axes) if axes else np.eye(3)
        c_mat = euler_to_matrix(bone.axis[None, :], bone.axis_order)[0]
        local = c_mat @ m @ c_mat.T
        p = skel.parents[i]
        if p < 0:
            rotations[:, i] = local
            positions[:, i] = trans + skel.root_position
        else:
            rotations[:, i] = rotations[:, p] @ local
            positions[:, i] = positions[:, p] + rotations[:, i] @ (bone.direction * bone.length)
    return positions, rotations
