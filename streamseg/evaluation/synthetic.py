"""Synthetic 1-D sequences of section 5.1 (Zhou et al. 2008), for the ACA benchmarks and tests.

Each of the 4 classes has a template of uniform random integers in 1..20 (length 10-15); a
segment is its class template resampled (time-warped) to a random length in 10..15. After every
frame a noise frame (uniform integer in 1..20) is inserted with probability ``p_noise``; it
belongs to the segment it falls in. Segment classes are drawn uniformly, never the same class
twice in a row (otherwise two segments would be one).
"""

from __future__ import annotations

import numpy as np


def synthetic_sequence(n_segments, p_noise, rng, k=4, lo=10, hi=15, vmax=20):
    """Return ``x`` (n,) float64 values and ``truth`` (n,) int64 frame classes."""
    templates = [rng.integers(1, vmax + 1, rng.integers(lo, hi + 1)) for _ in range(k)]
    xs, ys = [], []
    prev = -1
    for _ in range(n_segments):
        c = int(rng.choice([c for c in range(k) if c != prev]))
        prev = c
        w = int(rng.integers(lo, hi + 1))
        t = templates[c]
        idx = np.floor(np.linspace(0, len(t), w, endpoint=False)).astype(int)
        for v in t[idx]:
            xs.append(v)
            ys.append(c)
            if rng.random() < p_noise:
                xs.append(rng.integers(1, vmax + 1))
                ys.append(c)
    return np.asarray(xs, dtype=np.float64), np.asarray(ys, dtype=np.int64)
