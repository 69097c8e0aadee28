"""Incremental LOF over a ring buffer of count vectors (numba). Private.

The values are :func:`streamseg._kernels.lof.lof_batch`'s (scikit-learn's LOF with cosine
distance, ties by age) after every insert and eviction, maintained as Pokrajac, Lazarevic,
Latecki (2007) do: after a change only the points whose k-neighbour list changed (set A), whose
lrd depends on a changed k-distance (B = A + points with a k-neighbour in A) and whose LOF
depends on a changed lrd (C = B + points with a k-neighbour in B) are recomputed. The streaming
detector evicts and inserts before one update (:func:`ext_evict` then :func:`ext_insert`): B
and C are derived from the final lists, so the values are those of two separate updates.

State (one set per stream), capacity N slots, candidate lists of length K >= k:

- ``vecs`` int16 (N, d) integer counts (any integer dtype; int16 with
  ``columns * window**2 < 2**31`` lets :func:`_distances_to` sum in int32), ``norms`` float64
  (N,), ``seqs`` int64 (N,) (-1 = empty), ``centres`` int64 (N,) time of each point (frames),
  for the exclusion zone;
- the candidate lists: ``nn_idx`` int32 (N, K) slots, ``nn_d`` float64 (N, K), ``nn_key``
  int64 (N, K) neighbour seqs, ``nn_cnt`` int64 (N,) lengths, ``trunc`` uint8 (N,) 1 if an
  eligible point is missing from the list;
- ``lrd``, ``lof`` float64 (N,);
- the reverse lists: ``rev`` int32 (N, R), row ``q`` the slots whose candidate list holds
  ``q`` (unordered, first ``rev_cnt[q]``), ``rev_cnt`` int32 (N,); ``rev_cnt[q] > R``: more
  than ``R`` lists hold ``q`` and its row is not kept (the kernels then scan every list for
  it, as without reverse lists);
- ``gate`` float64 (N,): a new point enters the list of ``p`` when its distance is below
  ``gate[p]`` (the last candidate's distance; +inf for a complete list with room; 0 for
  an empty slot: no distance is below it), so an insert finds the lists it enters in one
  contiguous array;
- scratch: ``mark`` int64 (N,) zero between calls (1 = A, 2 = B, 3 = C), ``queue`` int32
  (N + 1,): the marked slots in the order marked, their number in ``queue[N]``.

Each list holds the exact nearest ``nn_cnt[p]`` points in (distance, seq) order; the first
``min(k, nn_cnt[p])`` are the k-neighbours. The K - k extra candidates let an eviction shorten
a list instead of forcing a rescan of the buffer: a rescan is needed only when a truncated list
falls below k. A list is never truncated below k, so when it is shorter it is complete. The
reverse lists make an update cost what it changes: an eviction visits the lists that hold the
evicted point, B and C are found from A through them, instead of passes over the buffer.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from streamseg._kernels.lof import _insert_sorted, lof_of, lrd_of

#: the buffer's arrays, in the order of the state tuple ``buf`` every kernel here takes
FIELDS = (
    "vecs",
    "norms",
    "seqs",
    "nn_idx",
    "nn_d",
    "nn_key",
    "nn_cnt",
    "trunc",
    "lrd",
    "lof",
    "mark",
    "centres",
    "rev",
    "rev_cnt",
    "queue",
    "gate",
)


@njit(cache=True, nogil=True, inline="always")
def _rev_add(rev, rev_cnt, q, p):
    """Record that ``p``'s list holds ``q``."""
    c = rev_cnt[q]
    if c < rev.shape[1]:
        rev[q, c] = p
        rev_cnt[q] = c + 1
    else:
        rev_cnt[q] = rev.shape[1] + 1  # too many to keep: scanned for instead


@njit(cache=True, nogil=True, inline="always")
def _rev_drop(rev, rev_cnt, q, p):
    """Record that ``p``'s list no longer holds ``q``."""
    c = rev_cnt[q]
    if c > rev.shape[1]:
        return
    for u in range(c):
        if rev[q, u] == p:
            rev[q, u] = rev[q, c - 1]
            rev_cnt[q] = c - 1
            return


@njit(cache=True, nogil=True, inline="always")
def _mark_changed(mark, queue, p):
    """Put ``p`` in A (its k-neighbours changed)."""
    if mark[p] == 0:
        n = queue.shape[0] - 1
        queue[queue[n]] = p
        queue[n] += 1
    mark[p] = 1


@njit(cache=True, nogil=True, inline="always")
def _set_gate(nn_d, nn_cnt, trunc, gate, p):
    """``gate[p]`` from ``p``'s list: the newest point, last among equal distances, enters a
    full or truncated list only when strictly closer than its last candidate."""
    c = nn_cnt[p]
    if c > 0 and (c == nn_d.shape[1] or trunc[p]):
        gate[p] = nn_d[p, c - 1]
    else:
        gate[p] = np.inf


@njit(cache=True, nogil=True, inline="always")
def _has_marked(nn_idx, nn_cnt, mark, p, k, top):
    """Whether a k-neighbour of ``p`` carries a mark in ``1 .. top``."""
    hit = False
    for t in range(min(nn_cnt[p], k)):
        m = mark[nn_idx[p, t]]
        hit |= (m >= 1) & (m <= top)
    return hit


@njit(cache=True, nogil=True)
def _grow(seqs, nn_idx, nn_cnt, mark, rev, rev_cnt, queue, lo, hi, k, kind):
    """Mark (as ``kind``) and queue every live unmarked point with a k-neighbour among the
    queued points ``lo .. hi`` (marked ``1 .. kind - 1``); return the new queue length."""
    n = queue.shape[0] - 1
    m = hi
    full = False
    for i in range(lo, hi):
        q = queue[i]
        c = rev_cnt[q]
        if c > rev.shape[1]:
            full = True
            continue
        for u in range(c):
            p = rev[q, u]
            if mark[p] != 0 or seqs[p] < 0:
                continue
            for t in range(min(nn_cnt[p], k)):
                if nn_idx[p, t] == q:
                    mark[p] = kind
                    queue[m] = p
                    m += 1
                    break
    if full:  # a point held by too many lists: look at every list
        for p in range(n):
            if mark[p] != 0 or seqs[p] < 0:
                continue
            if _has_marked(nn_idx, nn_cnt, mark, p, k, kind - 1):
                mark[p] = kind
                queue[m] = p
                m += 1
    return m


@njit(cache=True, nogil=True)
def _update_lrd_lof(seqs, nn_idx, nn_d, nn_cnt, lrd, lof, mark, rev, rev_cnt, queue, k):
    """Recompute lrd for B and LOF for C, given the changed set A queued and marked 1.

    B is A plus every point with a k-neighbour in A (its reach-distances changed), C is B plus
    every point with a k-neighbour in B (its lrd ratios changed), found through the reverse
    lists. lrd reads the lists only, LOF the lrd of B, so the order of the points changes no
    value. Returns the number of LOF values recomputed (``|C|``); the marks are cleared.
    """
    n = queue.shape[0] - 1
    n_a = queue[n]
    n_b = _grow(seqs, nn_idx, nn_cnt, mark, rev, rev_cnt, queue, 0, n_a, k, 2)
    for i in range(n_b):
        p = queue[i]
        if seqs[p] >= 0:
            lrd[p] = lrd_of(nn_idx, nn_d, nn_cnt, p, k)
    n_c = _grow(seqs, nn_idx, nn_cnt, mark, rev, rev_cnt, queue, 0, n_b, k, 3)
    n_updated = 0
    for i in range(n_c):
        p = queue[i]
        mark[p] = 0
        if seqs[p] < 0:
            continue
        n_updated += 1
        lof[p] = lof_of(nn_idx, nn_cnt, lrd, p, k)
    queue[n] = 0
    return n_updated


@njit(cache=True, nogil=True)
def _distances_to(vecs, norms, p, out):
    """``1 - cos`` of row ``p`` to every row (empty slots too) into ``out``, in two tight
    loops the compiler vectorizes: the integer dot products, then per pair the same float
    operations as :func:`streamseg._kernels.lof._cosdist` (so the same values). The products
    and sums stay in int32 (16 multiply-adds per instruction on int16 rows): exact for counts
    of at most ``window`` frames while ``columns * window**2 < 2**31``, which
    :class:`streamseg.online.StreamingLOFSegmenter` checks."""
    a = vecs[p]
    for j in range(vecs.shape[0]):
        b = vecs[j]
        dot = np.int32(0)
        for d in range(a.shape[0]):
            dot = np.int32(dot + np.int32(np.int32(a[d]) * np.int32(b[d])))
        out[j] = float(dot)
    ni = norms[p]
    for j in range(vecs.shape[0]):
        den = np.sqrt(ni * norms[j])
        r = 1.0 - out[j] / den if den != 0.0 else 1.0
        out[j] = r if r >= 0.0 else 0.0


@njit(cache=True, nogil=True)
def _own_list(buf, p, dist, excl):
    """Build the candidate list of ``p`` (empty on entry) from its distances ``dist`` to
    every slot: the K nearest eligible points, ``trunc`` and the reverse lists of its
    members."""
    seqs, nn_idx, nn_d, nn_key, nn_cnt, trunc = buf[2:8]
    centres, rev, rev_cnt = buf[11], buf[12], buf[13]
    kk = nn_idx.shape[1]
    cnt = 0
    n_elig = 0
    for j in range(seqs.shape[0]):
        if j == p or seqs[j] < 0 or abs(centres[p] - centres[j]) < excl:
            continue
        n_elig += 1
        dj = dist[j]
        if (
            cnt < kk
            or dj < nn_d[p, kk - 1]
            or (dj == nn_d[p, kk - 1] and seqs[j] < nn_key[p, kk - 1])
        ):
            cnt = _insert_sorted(nn_idx[p], nn_d[p], nn_key[p], cnt, kk, j, dj, seqs[j])
    nn_cnt[p] = cnt
    trunc[p] = 1 if n_elig > kk else 0
    _set_gate(nn_d, nn_cnt, trunc, buf[15], p)
    for t in range(cnt):
        _rev_add(rev, rev_cnt, nn_idx[p, t], p)


@njit(cache=True, nogil=True)
def _scan(buf, p, excl):
    """Rebuild the candidate list of ``p`` from the whole buffer, and the reverse lists of
    the points it leaves and enters."""
    nn_idx, nn_cnt, rev, rev_cnt = buf[3], buf[6], buf[12], buf[13]
    for t in range(nn_cnt[p]):
        _rev_drop(rev, rev_cnt, nn_idx[p, t], p)
    nn_cnt[p] = 0
    dist = np.empty(buf[2].shape[0])
    _distances_to(buf[0], buf[1], p, dist)
    _own_list(buf, p, dist, excl)


@njit(cache=True, nogil=True)
def _update(buf, k):
    """:func:`_update_lrd_lof` of the buffer ``buf``."""
    seqs, nn_idx, nn_d, nn_cnt = buf[2], buf[3], buf[4], buf[6]
    lrd, lof, mark, rev, rev_cnt, queue = buf[8], buf[9], buf[10], buf[12], buf[13], buf[14]
    return _update_lrd_lof(seqs, nn_idx, nn_d, nn_cnt, lrd, lof, mark, rev, rev_cnt, queue, k)


@njit(cache=True, nogil=True)
def ext_insert(buf, slot, vec, seq, k, excl):
    """Insert ``vec`` with sequence number ``seq`` into the empty ``slot`` of the buffer
    ``buf`` (the arrays of :data:`FIELDS`); update LOF.

    Candidate lists have ``K = nn_idx.shape[1] >= k`` entries (see the state notes above);
    ``centres[slot]`` must hold the new point's time; points closer than ``excl`` in time are
    not neighbours.

    Returns the number of points whose LOF was recomputed.
    """
    vecs, norms, seqs, nn_idx, nn_d, nn_key, nn_cnt, trunc = buf[:8]
    mark, centres, rev, rev_cnt, queue = buf[10:15]
    n_slots = seqs.shape[0]
    kk = nn_idx.shape[1]
    s = 0.0
    for d in range(vec.shape[0]):
        vecs[slot, d] = vec[d]
        s += float(vecs[slot, d]) * float(vecs[slot, d])
    norms[slot] = s
    seqs[slot] = seq
    rev_cnt[slot] = 0
    _mark_changed(mark, queue, slot)
    nn_cnt[slot] = 0
    dist = np.empty(n_slots)
    _distances_to(vecs, norms, slot, dist)
    _own_list(buf, slot, dist, excl)
    gate = buf[15]
    # every full list of an eligible point now leaves out the new point or its own last one
    for j in range(n_slots):
        full = nn_cnt[j] == kk and seqs[j] >= 0 and j != slot
        if full and abs(centres[slot] - centres[j]) >= excl:
            trunc[j] = 1
    for j in range(n_slots):
        dj = dist[j]
        # the lists the new point enters (empty slots never: their gate is 0)
        if dj >= gate[j] or j == slot or abs(centres[slot] - centres[j]) < excl:
            continue
        c = nn_cnt[j]
        if c == kk:
            _rev_drop(rev, rev_cnt, nn_idx[j, kk - 1], j)
        if c < k or dj < nn_d[j, k - 1]:
            _mark_changed(mark, queue, j)  # its k-neighbours changed
        nn_cnt[j] = _insert_sorted(nn_idx[j], nn_d[j], nn_key[j], c, kk, slot, dj, seq)
        _set_gate(nn_d, nn_cnt, trunc, gate, j)
        _rev_add(rev, rev_cnt, slot, j)
    return _update(buf, k)


@njit(cache=True, nogil=True)
def _unlist(buf, p, slot, k, excl):
    """Remove ``slot`` from ``p``'s list if it holds it (marking ``p`` when one of its
    k-neighbours left); rescan the list when it was truncated and fell below ``k``."""
    nn_idx, nn_d, nn_key, nn_cnt, trunc = buf[3:8]
    c = nn_cnt[p]
    t = c
    for u in range(c):  # no early exit: a branch-free search the compiler vectorizes
        if nn_idx[p, u] == slot:
            t = u
    if t == c:
        return
    if t < k:
        _mark_changed(buf[10], buf[14], p)
    for u in range(t, c - 1):
        nn_idx[p, u] = nn_idx[p, u + 1]
        nn_d[p, u] = nn_d[p, u + 1]
        nn_key[p, u] = nn_key[p, u + 1]
    nn_cnt[p] = c - 1
    if c - 1 < k and trunc[p]:
        _scan(buf, p, excl)
    else:
        _set_gate(nn_d, nn_cnt, trunc, buf[15], p)


@njit(cache=True, nogil=True)
def ext_evict(buf, slot, k, excl):
    """Remove the point in ``slot`` from every candidate list, marking (A) the points whose
    k-neighbours changed; lrd and LOF are left to the next update (:func:`ext_insert`, or
    :func:`ext_delete`).

    A list that held it among its first ``k`` changed its k-neighbours; it is rescanned only
    when it was truncated and now has fewer than ``k`` candidates.
    """
    seqs, nn_idx, nn_cnt, trunc, lrd, lof = buf[2], buf[3], buf[6], buf[7], buf[8], buf[9]
    rev, rev_cnt = buf[12], buf[13]
    seqs[slot] = -1
    for t in range(nn_cnt[slot]):
        _rev_drop(rev, rev_cnt, nn_idx[slot, t], slot)
    nn_cnt[slot] = 0
    trunc[slot] = 0
    buf[15][slot] = 0.0
    lof[slot] = 0.0
    lrd[slot] = 0.0
    c = rev_cnt[slot]
    if c > rev.shape[1]:
        for p in range(seqs.shape[0]):
            _unlist(buf, p, slot, k, excl)
    else:
        # rescans change the reverse lists of other points only (this one is in no list now)
        for u in range(c):
            _unlist(buf, rev[slot, u], slot, k, excl)
    rev_cnt[slot] = 0


@njit(cache=True, nogil=True)
def ext_delete(buf, slot, k, excl):
    """:func:`ext_evict` followed by the lrd/LOF update.

    Returns the number of points whose LOF was recomputed.
    """
    ext_evict(buf, slot, k, excl)
    return _update(buf, k)


@njit(cache=True, nogil=True)
def ext_rebuild(buf, k, excl):
    """Recompute everything :func:`ext_insert` derives from ``vecs``, ``seqs`` and
    ``centres``: norms, full candidate lists (``nn_idx.shape[1]`` nearest eligible points),
    ``trunc``, the reverse lists, lrd and LOF; the other slots' lists, lrd and LOF are zero (as
    after an eviction). The arrays must be zero on entry (fresh).

    The first ``k`` candidates of every list are the exact ``k`` nearest (ties by age) in the
    incremental state as in this one, and lrd/LOF sum the same values in the same order, so
    the result equals the incrementally maintained state in lrd and LOF bit for bit and in
    every later update; only the candidates beyond ``k`` may differ (they are then complete).

    Returns the number of points whose LOF was computed.
    """
    vecs, norms, seqs = buf[0], buf[1], buf[2]
    n_slots = seqs.shape[0]
    for p in range(n_slots):
        if seqs[p] < 0:
            continue
        s = 0.0  # the same float operations as ext_insert
        for d in range(vecs.shape[1]):
            s += float(vecs[p, d]) * float(vecs[p, d])
        norms[p] = s
    for p in range(n_slots):
        if seqs[p] >= 0:
            _scan(buf, p, excl)
            _mark_changed(buf[10], buf[14], p)
        else:
            buf[15][p] = 0.0
    return _update(buf, k)


@njit(cache=True, nogil=True)
def plain_lists(buf, k):
    """Lists of exactly ``k = nn_idx.shape[1]`` (no extra candidates, as Pokrajac et al.
    keep them), their ``trunc`` and reverse lists derived from the lists alone: a full list
    may be truncated, a shorter one is complete (a truncated list that lost a neighbour is
    rescanned at once). Call before each :func:`ext_insert` / :func:`ext_delete` of such a
    buffer (the tests' reference)."""
    seqs, nn_idx, nn_cnt, trunc, rev, rev_cnt = buf[2], buf[3], buf[6], buf[7], buf[12], buf[13]
    for p in range(seqs.shape[0]):
        trunc[p] = 1 if nn_cnt[p] == nn_idx.shape[1] else 0
        rev_cnt[p] = 0
    for p in range(seqs.shape[0]):
        if seqs[p] >= 0:
            _set_gate(buf[4], nn_cnt, trunc, buf[15], p)
            for t in range(nn_cnt[p]):
                _rev_add(rev, rev_cnt, nn_idx[p, t], p)
        else:
            buf[15][p] = 0.0
