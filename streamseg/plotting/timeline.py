"""Timelines: human segments above, then one row per method (its cuts, or its labelled segments).

One picture answers "where did each method cut, and where did people?" for a recording.
"""

from __future__ import annotations

import numpy as np


def timeline(path, n_frames: int, fps: float, truth, rows, *, title: str = "", key=None) -> None:
    """Write a PNG timeline.

    Parameters
    ----------
    path : str or Path
        Output PNG.
    n_frames : int
    fps : float
        For the seconds axis.
    truth : sequence of (start, end, label) or None
        Human segments (0-based, end exclusive); the same label gets the same colour.
    rows : sequence of (name, cuts, labels) or (name, cuts, labels, marks)
        One row per method: ``cuts`` (sequence of int frames) drawn as red ticks,
        ``labels`` ((n_frames,) int array or None; -1 = no label) drawn as coloured bands for
        methods that label frames, and optional ``marks`` (frames, e.g. when each cut was
        emitted) drawn as small arrows.
    title : str
    key : sequence of str, optional
        Names of the label values of ``rows``: value ``v`` is drawn in the colour of the
        human action ``key[v]`` (the truth's labels come first, in their order), and a colour
        key is drawn. Without it, label values get colours of their own.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = list(rows)
    n_rows = len(rows) + (truth is not None)
    fig, axes = plt.subplots(
        n_rows, 1, figsize=(12, 0.9 + 0.42 * n_rows), sharex=True, squeeze=False
    )
    axes = axes[:, 0]
    palette = plt.get_cmap("tab20").colors
    k = 0
    if truth is not None:
        names = list(dict.fromkeys(str(t[2]) for t in truth))
        ax = axes[0]
        for s, e, lab in truth:
            colour = palette[(2 * names.index(str(lab)) + 1) % len(palette)]
            ax.broken_barh([(s / fps, (e - s) / fps)], (0, 1), facecolors=colour, edgecolor="white")
            ax.text(
                (s + e) / 2 / fps, 0.5, str(lab), ha="center", va="center", fontsize=7, clip_on=True
            )
        ax.set_ylabel("human", rotation=0, ha="right", va="center", fontsize=8)
        k = 1
    for ax, (name, cuts, labels, *marks) in zip(axes[k:], rows):
        if labels is not None:
            labels = np.asarray(labels)
            b = np.concatenate([[0], np.flatnonzero(labels[1:] != labels[:-1]) + 1, [n_frames]])
            for s, e in zip(b[:-1], b[1:]):
                if labels[s] >= 0:
                    v = int(labels[s])
                    colour = palette[(2 * v + (key is not None)) % len(palette)]
                    ax.broken_barh([(s / fps, (e - s) / fps)], (0, 1), facecolors=colour)
        for c in cuts:
            ax.plot([c / fps, c / fps], [0.05, 0.95], color="#d62728", lw=1.4)
        for m in marks[0] if marks else ():
            ax.plot([m / fps], [0.15], marker=">", color="#d62728", ms=4)
        ax.set_ylabel(name, rotation=0, ha="right", va="center", fontsize=8)
    if truth is not None:
        for ax in axes[1:]:
            for s, _, _ in list(truth)[1:]:
                ax.axvline(s / fps, color="black", lw=0.6, ls=":")
    for ax in axes:
        ax.set_yticks([])
        ax.set_ylim(0, 1)
    axes[-1].set_xlim(0, n_frames / fps)
    axes[-1].set_xlabel("time (s)   (red: cuts; dotted: human cuts)")
    if title:
        axes[0].set_title(title, fontsize=10)
    if key is not None:
        from matplotlib.patches import Patch

        handles = [
            Patch(color=palette[(2 * v + 1) % len(palette)], label=str(name))
            for v, name in enumerate(key)
        ]
        fig.legend(
            handles=handles,
            loc="lower center",
            ncol=min(len(handles), 8),
            fontsize=7,
            frameon=False,
            bbox_to_anchor=(0.5, 0.0),
        )
        fig.tight_layout(rect=(0, 0.08, 1, 1))
    else:
        fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
