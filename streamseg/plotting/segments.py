"""Picture of a clustering segmentation (ACA): features over time with coloured segments."""

from __future__ import annotations

import numpy as np


def plot_segments(path, features, segments, *, fps=1.0, truth=None, title="") -> None:
    """Write a PNG: one band per segment coloured by label, features below.

    Parameters
    ----------
    path : str or Path
    features : (n, d) array
    segments : list of (start, end, label)
    fps : float
        To label the time axis in seconds.
    truth : (n,) int array, optional
        Ground-truth frame labels, drawn as a second band.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    X = np.asarray(features, dtype=float)
    n = X.shape[0]
    t = np.arange(n) / fps
    rows = 3 if truth is not None else 2
    fig, axes = plt.subplots(rows, 1, figsize=(12, 1.2 * rows + 2), sharex=True,
                             gridspec_kw={"height_ratios": [1] * (rows - 1) + [3]})
    cmap = plt.get_cmap("tab10")
    ax = axes[0]
    for s, e, lab in segments:
        ax.axvspan(s / fps, e / fps, color=cmap(lab % 10))
        ax.axvline(s / fps, color="k", lw=0.5)
    ax.set_yticks([])
    ax.set_ylabel("ACA")
    if truth is not None:
        ax = axes[1]
        truth = np.asarray(truth)
        b = np.concatenate([[0], np.flatnonzero(np.diff(truth)) + 1, [n]])
        for s, e in zip(b[:-1], b[1:], strict=True):
            if truth[s] >= 0:
                ax.axvspan(s / fps, e / fps, color=cmap(int(truth[s]) % 10))
        ax.set_yticks([])
        ax.set_ylabel("truth")
    axes[-1].plot(t, X, lw=0.6)
    axes[-1].set_xlabel("time (s)")
    axes[-1].set_xlim(0, n / fps)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
