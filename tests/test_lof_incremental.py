"""Incremental LOF (Pokrajac et al. 2007) against the naive full recomputation."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from streamseg._kernels.lof_buffer import (
    FIELDS,
    ext_delete,
    ext_evict,
    ext_insert,
    ext_rebuild,
    plain_lists,
)
from streamseg._kernels.peaks import robust_threshold, select_kth
from tests.naive import naive_cosine_lof, naive_robust_threshold, naive_sorted_neighbours

#: the buffers of the hypothesis cases: small rings and a small alphabet of counts (``alphabet``),
#: which make duplicate vectors and distance ties common, with and without an exclusion zone
BUFFERS = dict(
    data=st.data(),
    cap=st.integers(2, 14),
    k=st.integers(1, 5),
    d=st.integers(1, 6),
    alphabet=st.integers(1, 4),
    excl=st.sampled_from([0, 0, 3]),
)
#: candidates beyond k in the extended lists
EXTRA = st.integers(0, 6)


def draw_window(data, d, alphabet, t):
    """A window's count vector of ``d`` counts up to ``alphabet`` and its centre, 1 to 3
    frames after ``t``."""
    vec = data.draw(st.lists(st.integers(0, alphabet), min_size=d, max_size=d))
    return vec, t + data.draw(st.integers(1, 3))


class Buffer:
    """Thin driver of the incremental kernels over a ring of ``cap`` slots, lists of exactly
    ``k`` neighbours (Pokrajac et al.'s plain lists: :func:`plain_lists` before each update)."""

    plain = True

    def __init__(self, cap, k, d, excl=0, kk=None, r=None):
        kk = k if kk is None else kk
        r = 3 * kk if r is None else r
        self.k, self.excl, self.cap = k, excl, cap
        self.vecs = np.zeros((cap, d), dtype=np.int16)
        self.norms = np.zeros(cap)
        self.seqs = np.full(cap, -1, dtype=np.int64)
        self.nn_idx = np.zeros((cap, kk), dtype=np.int32)
        self.nn_d = np.zeros((cap, kk))
        self.nn_key = np.zeros((cap, kk), dtype=np.int64)
        self.nn_cnt = np.zeros(cap, dtype=np.int64)
        self.trunc = np.zeros(cap, dtype=np.uint8)
        self.lrd = np.zeros(cap)
        self.lof = np.zeros(cap)
        self.mark = np.zeros(cap, dtype=np.int64)
        self.centres = np.zeros(cap, dtype=np.int64)
        self.rev = np.zeros((cap, r), dtype=np.int32)
        self.rev_cnt = np.zeros(cap, dtype=np.int32)
        self.queue = np.zeros(cap + 1, dtype=np.int32)
        self.gate = np.zeros(cap)
        self.next, self.size = 0, 0

    def _args(self):
        if self.plain:
            plain_lists(self.buf(), self.k)
        return self.buf()

    def buf(self):
        return tuple(getattr(self, name) for name in FIELDS)

    def insert(self, vec, t):
        slot = self.next % self.cap
        self.centres[slot] = t
        n = ext_insert(
            self._args(), slot, np.asarray(vec, dtype=np.int16), self.next, self.k, self.excl
        )
        self.next += 1
        self.size += 1
        return n

    def evict(self, update=True):
        kernel = ext_delete if update else ext_evict
        n = kernel(self._args(), (self.next - self.size) % self.cap, self.k, self.excl)
        self.size -= 1
        return n

    def order(self):
        return np.arange(self.next - self.size, self.next) % self.cap


@settings(max_examples=150, deadline=None)
@given(**BUFFERS)
def test_incremental_lof_equals_naive_after_every_insert_and_evict(data, cap, k, d, alphabet, excl):
    buf = Buffer(cap, k, d, excl)
    ops = data.draw(st.lists(st.booleans(), min_size=1, max_size=40))
    t = 0
    for insert in ops:
        if insert or buf.size == 0:
            if buf.size == cap:
                buf.evict()
            vec, t = draw_window(data, d, alphabet, t)
            buf.insert(vec, t)
        else:
            buf.evict()
        o = buf.order()
        if len(o) == 0:
            continue
        ref = naive_cosine_lof(buf.vecs[o].astype(float), k, buf.centres[o], excl)
        np.testing.assert_allclose(buf.lof[o], ref, rtol=1e-12)
        assert np.isfinite(buf.lof[o]).all()


def test_incremental_updates_touch_few_points_on_clustered_stream():
    """The point of the incremental method: far fewer than n LOF recomputations per update."""
    rng = np.random.default_rng(0)
    cap, k = 300, 10
    buf = Buffer(cap, k, 16)
    centres = rng.integers(0, 40, (6, 16))
    touched = []
    for i in range(900):
        if buf.size == cap:
            touched.append(buf.evict())
        vec = centres[(i // 150) % 6] + rng.integers(0, 3, 16)
        touched.append(buf.insert(vec, i))
    o = buf.order()
    np.testing.assert_allclose(
        buf.lof[o], naive_cosine_lof(buf.vecs[o].astype(float), k), rtol=1e-12
    )
    assert np.median(touched[-600:]) < cap / 4


class ExtBuffer(Buffer):
    """Driver of the extended-candidate kernels: lists of ``kk >= k`` candidates, kept
    between updates with their reverse lists (of ``r`` entries: small ones overflow)."""

    plain = False

    def __init__(self, cap, k, kk, d, excl=0, r=None):
        super().__init__(cap, k, d, excl, kk, r)


@settings(max_examples=150, deadline=None)
@given(**BUFFERS, extra=EXTRA, r=st.sampled_from([None, None, 1, 2]))
def test_extended_candidate_lists_are_exact_and_change_no_value(
    data, cap, k, extra, d, alphabet, excl, r
):
    """Lists of k + extra candidates: each list is the exact (distance, age) prefix of all
    eligible points, at least k long unless fewer are eligible, complete unless flagged
    truncated; the LOF equals the naive one and, bit for bit, the plain k-list kernels'. An
    eviction followed by an insert may update lrd/LOF once for both (``ext_evict``). The
    reverse lists name exactly the lists holding each point, or are marked overflowed (``r``
    entries of 1 or 2 overflow often: the kernels then scan every list)."""
    ext = ExtBuffer(cap, k, k + extra, d, excl, r)
    plain = Buffer(cap, k, d, excl)
    ops = data.draw(
        st.lists(st.sampled_from(["insert", "evict", "replace"]), min_size=1, max_size=40)
    )
    t = 0
    for op in ops:
        if op == "evict" and ext.size > 0:
            ext.evict()
            plain.evict()
        else:
            vec, t = draw_window(data, d, alphabet, t)
            if ext.size == cap:
                ext.evict(update=op != "replace")
                plain.evict()
            ext.insert(vec, t)
            plain.insert(vec, t)
        o = ext.order()
        if len(o) == 0:
            continue
        x = ext.vecs[o].astype(float)
        ref = naive_cosine_lof(x, k, ext.centres[o], excl)
        np.testing.assert_allclose(ext.lof[o], ref, rtol=1e-12)
        np.testing.assert_array_equal(ext.lof[o], plain.lof[o])
        pos = {int(slot): i for i, slot in enumerate(o)}
        for i, nb in enumerate(naive_sorted_neighbours(x, ext.centres[o], excl)):
            p, c = o[i], ext.nn_cnt[o[i]]
            assert min(k, len(nb)) <= c <= min(k + extra, len(nb))
            assert ext.trunc[p] or c == len(nb)
            got = [(ext.nn_d[p, t_], pos[int(ext.nn_idx[p, t_])]) for t_ in range(c)]
            assert got == nb[:c]
        assert_reverse_lists(ext, o)


def assert_reverse_lists(buf, live):
    """Each live point's reverse list holds exactly the lists that hold it (or overflowed),
    and its gate is its list's last candidate's distance (infinite with room)."""
    holders = {int(q): [] for q in live}
    for p in live:
        for t_ in range(buf.nn_cnt[p]):
            holders[int(buf.nn_idx[p, t_])].append(int(p))
    width = buf.rev.shape[1]
    for q, want in holders.items():
        c = buf.rev_cnt[q]
        if c > width:  # overflowed once: not kept until the point leaves
            assert c == width + 1
            continue
        assert sorted(buf.rev[q, :c].tolist()) == sorted(want)
    assert not buf.mark.any() and buf.queue[-1] == 0
    for p in live:  # the gate: where a new point enters the list
        c, kk = buf.nn_cnt[p], buf.nn_idx.shape[1]
        closed = c > 0 and (c == kk or buf.trunc[p])
        assert buf.gate[p] == (buf.nn_d[p, c - 1] if closed else np.inf)


def rebuilt(ext):
    """A fresh :class:`ExtBuffer` with only ``vecs``, ``seqs`` and ``centres`` copied from
    ``ext`` and the rest recomputed (what a restored checkpoint does)."""
    kk = ext.nn_idx.shape[1]
    out = ExtBuffer(ext.cap, ext.k, kk, ext.vecs.shape[1], ext.excl, ext.rev.shape[1])
    out.vecs[:], out.seqs[:], out.centres[:] = ext.vecs, ext.seqs, ext.centres
    out.next, out.size = ext.next, ext.size
    ext_rebuild(out.buf(), ext.k, ext.excl)
    return out


@settings(max_examples=150, deadline=None)
@given(**BUFFERS, extra=EXTRA)
def test_a_rebuilt_buffer_equals_the_incremental_one_now_and_after(
    data, cap, k, extra, d, alphabet, excl
):
    """Rebuilt from the vectors alone at any point, the buffer has the same LOF and lrd bit
    for bit, the same k-neighbour lists, and stays equal through later inserts and evictions
    (its candidate lists beyond k are complete, the incremental ones may be truncated)."""
    live = ExtBuffer(cap, k, k + extra, d, excl)
    ops = data.draw(
        st.lists(st.sampled_from(["insert", "evict", "rebuild"]), min_size=1, max_size=40)
    )
    twin, t = None, 0
    for op in ops:
        if op == "rebuild":
            twin = rebuilt(live)
        elif op == "evict" and live.size > 0:
            for b in (live, twin):
                if b is not None:
                    b.evict()
        else:
            vec, t = draw_window(data, d, alphabet, t)
            for b in (live, twin):
                if b is not None:
                    if b.size == cap:
                        b.evict(update=False)
                    b.insert(vec, t)
        o = live.order()
        if twin is None or len(o) == 0:
            continue
        np.testing.assert_array_equal(twin.lof[o], live.lof[o])
        np.testing.assert_array_equal(twin.lrd[o], live.lrd[o])
        for p in o:
            c = min(k, live.nn_cnt[p])
            assert twin.nn_cnt[p] >= c
            np.testing.assert_array_equal(twin.nn_idx[p, :c], live.nn_idx[p, :c])
            np.testing.assert_array_equal(twin.nn_d[p, :c], live.nn_d[p, :c])
        ref = naive_cosine_lof(live.vecs[o].astype(float), k, live.centres[o], excl)
        np.testing.assert_allclose(twin.lof[o], ref, rtol=1e-12)


def test_extended_lists_on_a_clustered_stream_equal_plain_lists():
    """A longer stream than the hypothesis cases, evicting with the deferred update the
    streaming detector uses: same LOF as the k-list kernels and the naive one."""
    rng = np.random.default_rng(1)
    cap, k = 120, 5
    ext, plain = ExtBuffer(cap, k, 2 * k, 8), Buffer(cap, k, 8)
    centres = rng.integers(0, 30, (4, 8))
    for i in range(500):
        if ext.size == cap:
            ext.evict(update=False)
            plain.evict()
        vec = centres[(i // 40) % 4] + rng.integers(0, 3, 8)
        ext.insert(vec, i)
        plain.insert(vec, i)
    o = ext.order()
    np.testing.assert_array_equal(ext.lof[o], plain.lof[o])
    np.testing.assert_allclose(
        ext.lof[o], naive_cosine_lof(ext.vecs[o].astype(float), k), rtol=1e-12
    )
    assert (ext.nn_cnt[o] >= k).all()


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.sampled_from([0.5, 1.0, 1.0, 1.25, 2.0, 3.0]) | st.floats(0, 10), min_size=1, max_size=60
    ),
    st.floats(0, 3),
)
def test_robust_threshold_by_selection_equals_sorting(values, n_mads):
    y = np.array(values)
    assert robust_threshold(y, len(y), n_mads, np.empty(len(y))) == naive_robust_threshold(
        y, n_mads
    )
    y[len(y) // 2] = np.nan  # NaN: the sorting path, NaN last as before
    got = robust_threshold(y, len(y), n_mads, np.empty(len(y)))
    want = naive_robust_threshold(y, n_mads)
    assert got == want or (np.isnan(got) and np.isnan(want))


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.integers(0, 5).map(float) | st.floats(-5, 5), min_size=1, max_size=50), st.data()
)
def test_select_kth_partitions_like_a_sort(values, data):
    a = np.array(values)
    kth = data.draw(st.integers(0, len(a) - 1))
    w = a.copy()
    v = select_kth(w, len(w), kth)
    assert v == w[kth] == np.sort(a)[kth]
    assert (w[:kth] <= v).all() and (w[kth + 1 :] >= v).all()
    np.testing.assert_array_equal(np.sort(w), np.sort(a))
