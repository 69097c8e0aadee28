"""Picture of a repetition segmentation (matplotlib imported only when called)."""

from __future__ import annotations

import numpy as np


def title(segmenter, sets=None) -> str:
    """The picture's title: the count, or why there is none (never a count of a take that
    is not repetitive)."""
    if sets is not None and len(sets) > 1:
        rep = [st for st in sets if st["repetitive"]]
        if not rep:
            return f"{len(sets)} action sets, none repetitive: 0 repetitions"
        counts = ", ".join(str(st["count"]) for st in rep)
        return (f"{sum(st['count'] for st in rep)} repetitions in {len(rep)} repetitive "
                f"set(s) of {len(sets)} ({counts})")
    if not segmenter.repetitive_:
        return f"not repetitive: 0 repetitions ({segmenter.reason_})"
    return (f"{segmenter.count_} repetitions, primary frequency "
            f"{segmenter.primary_frequency_hz_:.2f} Hz")


def plot_repetitions(path, segmenter, truth=None, sets=None) -> None:
    """Write a PNG: band-passed selected parameters and their squared-velocity curve.

    Parameters
    ----------
    path : str or Path
        Output PNG.
    segmenter : RepetitionSegmenter
        A fitted segmenter.
    truth : list of (start, end), optional
        True repetitions, drawn as grey lines at their boundaries.
    sets : list of dict, optional
        Action sets (``segment --method rep`` JSON "sets"): shaded, their repetitions drawn.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as err:  # plotting is an optional extra
        from streamseg.exceptions import ParameterError

        raise ParameterError("--plot needs matplotlib: pip install 'streamseg[plot]'") from err
    a = segmenter.analysis_
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(11, 6), sharex=True)
    reps = segmenter.repetitions_
    if sets is not None:
        reps = [(r["start"], r["end"]) for st in sets for r in st["repetitions"]]
        for st in sets:
            for ax in (ax1, ax2):
                ax.axvspan(st["start"] / segmenter.fps_, st["end"] / segmenter.fps_,
                           color=f"C{st['label'] % 10}", alpha=0.12, lw=0)
            ax1.text(st["start"] / segmenter.fps_, 1.0, f"{st['count']}" if st["repetitive"]
                     else "-", transform=ax1.get_xaxis_transform(), fontsize=8, va="bottom")
    if a is None:  # still or too short: nothing was analysed
        ax1.text(0.5, 0.5, segmenter.reason_, transform=ax1.transAxes, ha="center")
        fig.suptitle(title(segmenter, sets))
        fig.savefig(path, dpi=90)
        plt.close(fig)
        return
    t = np.arange(a.speed2.shape[0]) / segmenter.fps_
    for j, col in enumerate(a.selected):
        ax1.plot(t, a.filtered[:, j], lw=0.8, label=segmenter.param_names_[col])
    ax1.set_ylabel("band-passed parameters")
    ax1.legend(fontsize=6, ncol=4, loc="upper right")
    ax2.plot(t, a.speed2, color="k", lw=0.8, label="sum of squared velocities (eq. 10)")
    routine = sets is not None and len(sets) > 1
    if routine:  # the curves are the whole take's; each set was analysed on its own
        ax1.set_ylabel("band-passed parameters\n(whole take)")
    if a.candidates.size and not routine:
        ax2.scatter(t[a.candidates], a.speed2[a.candidates], c=a.labels, cmap="tab10", s=25,
                    zorder=3, label=f"candidates (K*={a.k_star} groups)")
    for i, (s, e) in enumerate(reps):
        for ax in (ax1, ax2):
            ax.axvline(s / segmenter.fps_, color="tab:red", lw=1.0,
                       label="repetition boundaries" if (i == 0 and ax is ax2) else None)
        if i == len(reps) - 1 or reps[i + 1][0] != e:
            for ax in (ax1, ax2):
                ax.axvline(e / segmenter.fps_, color="tab:red", lw=1.0)
    for s, _ in truth or []:
        ax2.axvline(s / segmenter.fps_, color="0.6", ls="--", lw=0.8)
    ax2.set_xlabel("seconds")
    ax2.legend(fontsize=7, loc="upper right")
    fig.suptitle(title(segmenter, sets))
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
