"""Picture of a repetition segmentation (matplotlib imported only when called)."""

from __future__ import annotations

import numpy as np


def plot_repetitions(path, segmenter, truth=None) -> None:
    """Write a PNG: band-passed selected parameters and their squared-velocity curve.

    Parameters
    ----------
    path : str or Path
        Output PNG.
    segmenter : RepetitionSegmenter
        A fitted segmenter.
    truth : list of (start, end), optional
        True repetitions, drawn as grey lines at their boundaries.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as err:  # plotting is an optional extra
        from streamseg.exceptions import ParameterError

        raise ParameterError("--plot needs matplotlib: pip install 'streamseg[plot]'") from err
    a = segmenter.analysis_
    t = np.arange(a.speed2.shape[0]) / segmenter.fps_
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(11, 6), sharex=True)
    for j, col in enumerate(a.selected):
        ax1.plot(t, a.filtered[:, j], lw=0.8, label=segmenter.param_names_[col])
    ax1.set_ylabel("band-passed parameters")
    ax1.legend(fontsize=6, ncol=4, loc="upper right")
    ax2.plot(t, a.speed2, color="k", lw=0.8, label="sum of squared velocities (eq. 10)")
    if a.candidates.size:
        ax2.scatter(t[a.candidates], a.speed2[a.candidates], c=a.labels, cmap="tab10", s=25,
                    zorder=3, label=f"candidates (K*={a.k_star} groups)")
    for i, (s, e) in enumerate(segmenter.repetitions_):
        for ax in (ax1, ax2):
            ax.axvline(s / segmenter.fps_, color="tab:red", lw=1.0,
                       label="repetition boundaries" if (i == 0 and ax is ax2) else None)
        if i == len(segmenter.repetitions_) - 1:
            for ax in (ax1, ax2):
                ax.axvline(e / segmenter.fps_, color="tab:red", lw=1.0)
    for s, _ in truth or []:
        ax2.axvline(s / segmenter.fps_, color="0.6", ls="--", lw=0.8)
    ax2.set_xlabel("seconds")
    ax2.legend(fontsize=7, loc="upper right")
    fig.suptitle(f"{segmenter.count_} repetitions, primary frequency "
                 f"{segmenter.primary_frequency_hz_:.2f} Hz")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
