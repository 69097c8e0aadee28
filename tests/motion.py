"""Synthetic feature streams shared by the relabel tests."""

from __future__ import annotations

import numpy as np

FPS = 120.0


def cyclic_blocks(levels, seconds=3.0, seed=0, d=6):
    """Blocks of a noisy cyclic motion around each level (radians), one block per level:
    shape (len(levels) * seconds * FPS, d)."""
    rng = np.random.default_rng(seed)
    n = int(seconds * FPS)
    t = np.arange(n)[:, None]
    return np.concatenate([lv + 0.3 * np.sin(2 * np.pi * t / 60 + np.arange(d))
                           + rng.normal(0, 0.02, (n, d)) for lv in levels])
