"""Speed of one full ACA fit (10 restarts) on synthetic section-5.1 sequences.

Sequences of about 250, 1,100 and 4,600 frames (20, 88 and 368 segments of 10-15 frames, no
noise), equality kernel, lengths 10..15, 10 random restarts: the median of 3 fits. Reference
times of the authors' code under Octave on this machine: 1.1 s, 6.9 s and 102 s (86 s of it
ACA proper). The in-run baseline is the same algorithm (same initializations, same
coordinate descent, same O(n^2 w) active-matrix DP) with the DP step written in plain numpy
(vectorized over old segments and candidate lengths, Python loops over frames and columns);
it is run on the two smaller sizes only (it would take minutes at 4,600) and must reach the
same objective. CPU time is printed too: on a shared machine wall time includes waiting.

Run: ``.venv/bin/python benchmarks/aca_speed.py [--jobs 1] [--repeats 3]``
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from unittest import mock

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _aca_synth import synthetic_sequence  # noqa: E402

import streamseg.offline.aca as aca_module  # noqa: E402
from streamseg.offline.aca import ACA  # noqa: E402

REFERENCE = {20: 1.1, 88: 6.9, 368: 102.0}


def numpy_dp_step(K, starts, ends, labels, n_c, const, wmin, wmax, *, binary=None):
    """Plain-numpy twin of the DP step (same results as ``streamseg.offline.aca.dp_step``)."""
    n = K.shape[0]
    m = starts.size
    k = n_c.size
    lens = ends - starts
    lmax = int(lens.max())
    W = wmax + 1
    prev = np.full((lmax + 1, W, m), -np.inf)
    prev[0, 0, :] = 0.0
    cols = np.arange(m)
    idx = starts[None, :] + np.arange(lmax)[:, None]  # (lmax, m) frame of column b+1
    valid = np.arange(1, lmax + 1)[:, None] <= lens[None, :]
    idx = np.where(valid, idx, 0)
    inv = 1.0 / (np.arange(W)[:, None] + lens[None, :])
    onehot = np.zeros((m, k))
    onehot[cols, labels] = 1.0
    L = np.full(n + 1, np.inf)
    L[0] = 0.0
    S = np.zeros(n + 1, dtype=np.int64)
    lab = np.zeros(n + 1, dtype=np.int64)
    use = n_c > 0
    for v in range(1, n + 1):
        kv = np.where(valid, K[v - 1][idx], 0.0)  # (lmax, m)
        cur = np.full_like(prev, -np.inf)
        cur[0, 0, :] = 0.0
        for b in range(1, lmax + 1):
            x = kv[b - 1][None, :]
            cur[b, 1:] = np.maximum(np.maximum(prev[b, :-1] + x, prev[b - 1, :-1] + 2 * x),
                                    cur[b - 1, 1:] + x)
        last = cur[lens, :, cols]  # (m, W); -inf only for lengths w > v, never used
        last = np.where(np.isfinite(last), last, 0.0)
        f = (last.T * inv) @ onehot  # (W, k)
        dist = 1.0 - 2.0 * f / np.where(use, n_c, 1.0) + const
        dist[:, ~use] = np.inf
        top = min(wmax, v)
        if top >= wmin:
            ws = np.arange(wmin, top + 1)
            best_c = np.argmin(dist[ws], axis=1)
            total = L[v - ws] + dist[ws, best_c]
            i = int(np.argmin(total))
            if total[i] < np.inf:
                L[v], S[v], lab[v] = total[i], v - ws[i], best_c[i]
        prev = cur
    bounds = []
    v = n
    while v > 0:
        bounds.append((S[v], v, lab[v]))
        v = S[v]
    bounds.reverse()
    arr = np.array(bounds, dtype=np.int64).reshape(-1, 3)
    return arr[:, 0].copy(), arr[:, 1].copy(), arr[:, 2].copy(), L[n]


def timed_fit(x, jobs, baseline=False):
    model = ACA(4, 10, 15, n_init=10, kernel="equality", random_state=0, n_jobs=jobs)
    ctx = mock.patch.object(aca_module, "dp_step", numpy_dp_step) if baseline else (
        mock.patch.object(aca_module, "dp_step", aca_module.dp_step))
    with ctx:
        t0, c0 = time.perf_counter(), time.process_time()
        model.fit(x)
        return time.perf_counter() - t0, time.process_time() - c0, model.objective_


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=1, help="threads for restarts (default 1)")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    ACA(2, 2, 3, n_init=1, kernel="equality").fit(np.arange(12.0) % 3)  # compile / load cache
    print(f"{'frames':>6} {'wall s':>7} {'cpu s':>7} {'numpy s':>8} {'vs numpy':>8} "
          f"{'octave s':>8} {'vs octave':>9}")
    for n_seg, ref in REFERENCE.items():
        x, _ = synthetic_sequence(n_seg, 0.0, np.random.default_rng(n_seg))
        runs = [timed_fit(x, args.jobs) for _ in range(args.repeats)]
        wall = float(np.median([r[0] for r in runs]))
        cpu = float(np.median([r[1] for r in runs]))
        base = "-"
        ratio = "-"
        if n_seg <= 88:
            b_wall, _, b_obj = timed_fit(x, 1, baseline=True)
            if not np.isclose(b_obj, runs[0][2]):
                raise AssertionError(f"numpy baseline objective {b_obj} != {runs[0][2]}")
            base = f"{b_wall:.2f}"
            ratio = f"{b_wall / wall:.1f}x"
        print(f"{len(x):6d} {wall:7.2f} {cpu:7.2f} {base:>8} {ratio:>8} {ref:8.1f} "
              f"{ref / wall:8.1f}x")


if __name__ == "__main__":
    main()
