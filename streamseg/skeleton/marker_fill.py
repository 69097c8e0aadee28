"""Lost optical markers placed again from the markers that remain on their segment.

Cameras lose markers all the time: for a few frames (a gap the readers interpolate), for long
stretches, or for a whole take (a marker that fell off or was never labelled). A marker on a
segment that carries others (a *cluster*: the four pelvis markers, the trunk's, a wrist bar
with the forearm, a shank, a foot) moves rigidly with them: where it is lost and at least
three of the others are seen, it is placed by the rigid motion (least-squares rotation and
translation, Kabsch 1976) that carries those markers from the last frame before and the first
after where all of them and it were seen, the two placements blended by time. A pelvis
marker lost in every frame is mirrored from its twin across the pelvis's mid-plane (the
plane half-way between the other pair, across their axis), as is one the file leaves out
altogether (:func:`with_absent_pair_markers`). What is left lost stays NaN;
:func:`streamseg.skeleton.marker_sets.joint_positions` then falls back, frame by frame, on
the other markers of the joint.
"""

from __future__ import annotations

import numpy as np

__all__ = ["LiveMarkerFill", "fill_from_clusters", "live_layout", "with_absent_pair_markers"]

#: a marker is reported when it is lost in at least this share of the frames
REPORT_SHARE = 0.1


def _present(X):
    return np.isfinite(X).all(axis=-1)


def _kabsch_place(A, B, a_m):
    """Marker positions ``a_m`` (k, 3) carried by the rigid motions taking ``A`` (k, p, 3)
    onto ``B`` (k, p, 3)."""
    ca, cb = A.mean(axis=1, keepdims=True), B.mean(axis=1, keepdims=True)
    H = np.einsum("kpi,kpj->kij", A - ca, B - cb)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(np.einsum("kji,klj->kil", Vt, U)))
    D = np.zeros((len(d), 3, 3))
    D[:, 0, 0] = D[:, 1, 1] = 1.0
    D[:, 2, 2] = np.where(d == 0, 1.0, d)
    R = np.einsum("kji,kjl,kml->kim", Vt, D, U)  # V D U^T
    return np.einsum("kij,kj->ki", R, a_m - ca[:, 0]) + cb[:, 0]


def _rigid_fill(X, out, cols, m):
    """Fill marker column ``m`` of ``out`` where it is still lost, from the columns ``cols``
    of ``X`` (the markers as read) seen with it; returns the frames filled."""
    seen = _present(X[:, cols])  # (n, p)
    lost = ~_present(X[:, m])
    filled = 0
    patterns = {}
    for f in np.flatnonzero(~_present(out[:, m])):
        key = tuple(np.flatnonzero(seen[f]))
        if len(key) >= 3:
            patterns.setdefault(key, []).append(f)
    for key, frames in patterns.items():
        use = [cols[i] for i in key]
        ref = np.flatnonzero(~lost & _present(X[:, use]).all(axis=1))
        if ref.size == 0:
            continue
        frames = np.asarray(frames)
        # the last frame seen before and the first after: each places the marker, blended
        # by time (the markers' skin drifts slowly about the bone: no jump at either end)
        j = np.searchsorted(ref, frames)
        before, after = ref[np.clip(j - 1, 0, ref.size - 1)], ref[np.clip(j, 0, ref.size - 1)]
        before = np.where(j > 0, before, after)
        after = np.where(j < ref.size, after, before)
        B = X[frames][:, use]
        pb = _kabsch_place(X[before][:, use], B, X[before, m])
        pa = _kabsch_place(X[after][:, use], B, X[after, m])
        span = np.maximum(after - before, 1)
        w = np.clip((frames - before) / span, 0.0, 1.0)[:, None]
        out[frames, m] = (1.0 - w) * pb + w * pa
        filled += frames.size
    return filled


def _mirror(out, twin, pair):
    """``twin`` (n, 3) reflected across the plane through the middle of ``pair`` (two (n, 3)
    markers of the other side pair) perpendicular to their axis."""
    axis = pair[0] - pair[1]
    with np.errstate(invalid="ignore", divide="ignore"):
        nrm = axis / np.linalg.norm(axis, axis=1, keepdims=True)
    mid = (pair[0] + pair[1]) / 2
    return twin - 2 * np.sum((twin - mid) * nrm, axis=1, keepdims=True) * nrm


def fill_from_clusters(markers: np.ndarray, labels, clusters, pairs=()):
    """Markers lost in some frames placed from their cluster; pelvis markers lost in every
    frame mirrored from their twins.

    Parameters
    ----------
    markers : ndarray, shape (n_frames, n_markers, 3)
        NaN where a marker is lost.
    labels : sequence of str
    clusters : sequence of tuple of str
        Markers that move together (:attr:`MarkerSet.clusters`).
    pairs : sequence of ((str, str), (str, str))
        Two left/right pairs of one segment (the pelvis's ASIS and PSIS); a marker of one
        pair lost in every frame is its twin mirrored across the other pair's mid-plane.

    Returns
    -------
    markers : ndarray, shape (n_frames, n_markers, 3)
        A filled copy (the input when nothing was lost).
    notes : list of str
        One per marker lost in every frame or in at least :data:`REPORT_SHARE` of them: what
        was done.
    """
    from streamseg.skeleton.marker_sets import _index

    X = np.asarray(markers, dtype=np.float64)
    n = X.shape[0]
    if n == 0 or _present(X).all():
        return markers, []
    index = _index(labels)
    out = X.copy()
    notes = []
    lost_all = set()
    done: dict = {}  # marker column -> (frames lost, frames placed, markers used)
    for cluster in clusters:
        cols = [index[c.upper()] for c in cluster if c.upper() in index]
        for m in cols:
            lost = int((~_present(X[:, m])).sum())
            if lost == 0:
                continue
            if lost == n:
                lost_all.add(m)
                continue
            others = [c for c in cols if c != m]
            filled = _rigid_fill(X, out, others, m) if len(others) >= 3 else 0
            _, before, used = done.get(m, (lost, 0, []))
            done[m] = (
                lost,
                before + filled,
                used + ([c for c in others if c not in used] if filled else []),
            )
    for m, (lost, filled, used) in done.items():
        if lost >= REPORT_SHARE * n:
            notes.append(
                f"marker {labels[m]} lost in {lost / n:.0%} of the frames: "
                + (
                    f"placed in {filled} of them from the markers of its segment "
                    f"({' '.join(labels[c] for c in used)})"
                    if filled
                    else "not placed (fewer than three markers of its segment seen with it)"
                )
            )
    for (a, b), (c, d) in list(pairs) + [(q, p) for p, q in pairs]:
        have = [x.upper() in index for x in (a, b, c, d)]
        if not all(have):
            continue
        ia, ib, ic, id_ = (index[x.upper()] for x in (a, b, c, d))
        for m, twin in ((ia, ib), (ib, ia)):
            if (
                m in lost_all
                and twin not in lost_all
                and ic not in lost_all
                and id_ not in lost_all
            ):
                out[:, m] = _mirror(out, out[:, twin], (out[:, ic], out[:, id_]))
                lost_all.discard(m)
                notes.append(
                    f"marker {labels[m]} lost in every frame: placed as "
                    f"{labels[twin]} mirrored across the mid-plane of "
                    f"{labels[ic]} and {labels[id_]}"
                )
    for m in sorted(lost_all):
        notes.append(
            f"marker {labels[m]} lost in every frame: the joints made of it come "
            "from the other markers of the joint where there are some"
        )
    return out, notes


def with_absent_pair_markers(labels, markers, msets=None):
    """``(labels, markers)`` with a lost-in-every-frame (NaN) column added for each marker of
    a marker set's pairs (:attr:`MarkerSet.pairs`; ``msets``, default the built-in sets) that
    the file leaves out while the other three are there (so that :func:`fill_from_clusters`
    mirrors it)."""
    from streamseg.skeleton.marker_sets import MARKER_SETS, _index

    index = _index(labels)
    add = []
    for mset in MARKER_SETS.values() if msets is None else msets:
        for (a, b), (c, d) in mset.pairs:
            absent = [m for m in (a, b, c, d) if m.upper() not in index]
            if len(absent) == 1 and absent[0] not in add:
                add.append(absent[0])
    if not add:
        return list(labels), markers
    X = np.asarray(markers, dtype=np.float64)
    pad = np.full(X.shape[:1] + (len(add), 3), np.nan)
    return list(labels) + add, np.concatenate([X, pad], axis=1)


# --- live streams: the same placement, from the past only -----------------------------------


def live_layout(mset, labels):
    """``(clusters, pairs, labels)`` of a marker set for a live stream's marker names, as
    columns (the clusters' markers the stream has; the pairs whose four markers it has), for
    :class:`LiveMarkerFill`; None when there is nothing to place from."""
    from streamseg.skeleton.marker_sets import _index

    index = _index(labels)
    clusters = []
    for cluster in mset.clusters:
        cols = tuple(dict.fromkeys(index[c.upper()] for c in cluster if c.upper() in index))
        if len(cols) >= 4:  # a lost one needs three others
            clusters.append(cols)
    pairs = []
    for (a, b), (c, d) in mset.pairs:
        if all(x.upper() in index for x in (a, b, c, d)):
            pairs.append(tuple(tuple(index[x.upper()] for x in q) for q in ((a, b), (c, d))))
    if not clusters and not pairs:
        return None
    return tuple(clusters), tuple(pairs), tuple(str(n) for n in labels)


class LiveMarkerFill:
    """Lost markers of a live stream placed as frames come, from the past only.

    Frames with fewer markers than the layout's labels get NaN columns for the others (a
    pair's marker the stream leaves out: :func:`streamseg.skeleton.marker_map.stream_markers`).

    The rule of :func:`fill_from_clusters` without hindsight: a marker lost in a frame where
    at least three others of its cluster are seen is carried by the rigid motion of those
    from the last frame before where it was seen with them (the offline filler also blends in
    the first frame after, which a stream has not sent yet); a marker of a pair not seen yet
    in the stream is its twin mirrored across the other pair's mid-plane (offline: one lost
    in every frame of the take). The stored state is ``(refs, seen, told)``, plain arrays a
    stream's checkpoint holds (:attr:`state`): per cluster the cluster's markers at the last
    frame each member was seen with three others, the markers seen so far, the markers
    already reported (:meth:`fill` returns a note the first time one is placed).

    Parameters
    ----------
    layout : tuple
        :func:`live_layout`.
    state : tuple, optional
        A :attr:`state` to go on from (None: a stream's start).
    """

    __slots__ = ("clusters", "pairs", "labels", "state")

    def __init__(self, layout, state=None):
        self.clusters, self.pairs, self.labels = layout
        if state is None:
            refs = [np.full((len(c), len(c), 3), np.nan) for c in self.clusters]
            n = len(self.labels)
            state = (refs, np.zeros(n, dtype=bool), np.zeros(n, dtype=bool))
        self.state = state

    def fill(self, markers: np.ndarray):
        """``(markers, notes)``: frames ``(n, M, 3)`` with the lost markers placed (the input
        when none is), and one note per marker placed for the first time."""
        X = np.asarray(markers, dtype=np.float64)
        if X.shape[1] < len(self.labels):  # a pair's marker the stream leaves out
            pad = np.full((X.shape[0], len(self.labels) - X.shape[1], 3), np.nan)
            X = markers = np.concatenate([X, pad], axis=1)
        refs, seen, told = self.state
        present = _present(X)
        if present.all():
            for cols, R in zip(self.clusters, refs):
                R[:] = X[-1, list(cols)][None]
            seen[:] = True
            return markers, []
        out = X.copy()
        how = {}
        for cols, R in zip(self.clusters, refs):
            self._from_cluster(X, out, list(cols), R, how)
        for (a, b), (c, d) in list(self.pairs) + [(q, p) for p, q in self.pairs]:
            for m, twin in ((a, b), (b, a)):
                if seen[m]:
                    continue
                hit = present[:, m]
                before = np.arange(X.shape[0]) < (np.argmax(hit) if hit.any() else X.shape[0])
                ok = before & _present(out[:, [twin, c, d]]).all(axis=1) & ~_present(out[:, m])
                if ok.any():
                    out[ok, m] = _mirror(out[ok], out[ok, twin], (out[ok, c], out[ok, d]))
                    how.setdefault(
                        m,
                        f"placed as {self.labels[twin]} mirrored across the mid-plane of "
                        f"{self.labels[c]} and {self.labels[d]} until it is seen",
                    )
        seen |= present.any(axis=0)
        notes = []
        for m, text in how.items():
            if not told[m]:
                told[m] = True
                notes.append(f"marker {self.labels[m]} lost: {text}")
        return out, notes

    def _from_cluster(self, X, out, cols, R, how):
        P = X[:, cols]
        pres = _present(P)
        n_seen = pres.sum(axis=1)
        for i, m in enumerate(cols):
            good = np.flatnonzero(pres[:, i] & (n_seen - 1 >= 3))
            lost = np.flatnonzero(~pres[:, i] & ~_present(out[:, m]))
            if lost.size:
                # each lost frame's reference: the last frame before it that saw it with
                # three others, this packet's or an earlier one's (R)
                j = np.searchsorted(good, lost) - 1
                ref = np.repeat(R[i][None], lost.size, axis=0)
                ref[j >= 0] = P[good[j[j >= 0]]]
                use = pres[lost] & _present(ref)
                use[:, i] = False
                ok = (use.sum(axis=1) >= 3) & _present(ref[:, i])
                patterns = {}
                for k in np.flatnonzero(ok):
                    patterns.setdefault(tuple(np.flatnonzero(use[k])), []).append(k)
                for key, ks in patterns.items():
                    ks = np.asarray(ks)
                    sel = list(key)
                    out[lost[ks], m] = _kabsch_place(
                        ref[ks][:, sel], P[lost[ks]][:, sel], ref[ks, i]
                    )
                    how.setdefault(
                        m,
                        "placed from the markers of its segment ("
                        + " ".join(self.labels[cols[s]] for s in sel)
                        + ")",
                    )
            if good.size:
                R[i] = P[good[-1]]
