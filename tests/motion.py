"""Synthetic feature streams shared by the relabel tests, and the daemon's revisions of one."""

from __future__ import annotations

import numpy as np

FPS = 120.0


def cyclic_blocks(levels, seconds=3.0, seed=0, d=6):
    """Blocks of a noisy cyclic motion around each level (radians), one block per level:
    shape (len(levels) * seconds * FPS, d)."""
    rng = np.random.default_rng(seed)
    n = int(seconds * FPS)
    t = np.arange(n)[:, None]
    return np.concatenate(
        [
            lv + 0.3 * np.sin(2 * np.pi * t / 60 + np.arange(d)) + rng.normal(0, 0.02, (n, d))
            for lv in levels
        ]
    )


def revisions(algorithms, X, fps=FPS, history=6.0, interval=1.0):
    """The daemon's job function (``relabel_job.relabel``) every ``interval`` s over the last
    ``history`` s of ``X`` (n, d), no live cuts: per-frame ids of the newest revision (n,)
    and the last revision's window."""
    from streamseg.daemon.relabel_job import relabel

    n = X.shape[0]
    step, span = int(round(interval * fps)), int(round(history * fps))
    lab, previous = np.full(n, -1), None
    for t in list(range(step, n, step)) + [n]:
        s = max(0, t - span)
        res = relabel(algorithms, X[s:t], np.arange(s, t), fps, previous)
        previous = res.window
        for a, b, c in res.segments:
            lab[a:b] = c
    return lab, previous


def lof_input(positions, skeleton, fps=FPS):
    """What the default cut detector reads of joint positions (n, J, 3): the 17 bone features
    and the 2 root speeds (as the daemon computes them, with the skeleton's up axis)."""
    from streamseg.offline.lof import position_features

    return position_features(positions, skeleton, fps)
