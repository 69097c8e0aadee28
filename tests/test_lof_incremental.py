"""Incremental LOF (Pokrajac et al. 2007) against the naive full recomputation."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from streamseg._kernels.lof import inc_delete, inc_insert
from tests.naive import naive_cosine_lof


class Buffer:
    """Thin driver of the incremental kernels over a ring of ``cap`` slots."""

    def __init__(self, cap, k, d, excl=0):
        self.k, self.excl, self.cap = k, excl, cap
        self.vecs = np.zeros((cap, d), dtype=np.uint16)
        self.norms = np.zeros(cap)
        self.seqs = np.full(cap, -1, dtype=np.int64)
        self.nn_idx = np.zeros((cap, k), dtype=np.int64)
        self.nn_d = np.zeros((cap, k))
        self.nn_key = np.zeros((cap, k), dtype=np.int64)
        self.nn_cnt = np.zeros(cap, dtype=np.int64)
        self.lrd = np.zeros(cap)
        self.lof = np.zeros(cap)
        self.mark = np.zeros(cap, dtype=np.int64)
        self.centres = np.zeros(cap, dtype=np.int64)
        self.next, self.size = 0, 0

    def _args(self):
        return (self.vecs, self.norms, self.seqs, self.nn_idx, self.nn_d, self.nn_key,
                self.nn_cnt, self.lrd, self.lof, self.mark, self.centres)

    def insert(self, vec, t):
        slot = self.next % self.cap
        self.centres[slot] = t
        n = inc_insert(*self._args(), slot, np.asarray(vec, dtype=np.uint16), self.next,
                       self.k, self.excl)
        self.next += 1
        self.size += 1
        return n

    def evict(self):
        n = inc_delete(*self._args(), (self.next - self.size) % self.cap, self.k, self.excl)
        self.size -= 1
        return n

    def order(self):
        return np.arange(self.next - self.size, self.next) % self.cap


@settings(max_examples=150, deadline=None)
@given(data=st.data(), cap=st.integers(2, 14), k=st.integers(1, 5), d=st.integers(1, 6),
       alphabet=st.integers(1, 4), excl=st.sampled_from([0, 0, 3]))
def test_incremental_lof_equals_naive_after_every_insert_and_evict(data, cap, k, d, alphabet,
                                                                    excl):
    # a small alphabet of counts makes duplicate vectors and distance ties common
    buf = Buffer(cap, k, d, excl)
    ops = data.draw(st.lists(st.booleans(), min_size=1, max_size=40))
    t = 0
    for insert in ops:
        if insert or buf.size == 0:
            if buf.size == cap:
                buf.evict()
            vec = data.draw(st.lists(st.integers(0, alphabet), min_size=d, max_size=d))
            t += data.draw(st.integers(1, 3))
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
    np.testing.assert_allclose(buf.lof[o], naive_cosine_lof(buf.vecs[o].astype(float), k),
                               rtol=1e-12)
    assert np.median(touched[-600:]) < cap / 4
