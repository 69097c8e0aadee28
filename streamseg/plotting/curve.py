"""Pictures of a score curve with detected cuts and human segments (matplotlib, lazy).

Generic on purpose: any method with a per-window score (LOF, a change statistic) and cuts can
use :func:`plot_curve`. Layout after Xing et al. (2015), Figs 6-7: the curve on top, then the
detected segments and the human segments as coloured bars on a shared time axis.
"""

from __future__ import annotations

import numpy as np


def _bars(ax, spans, colours, fps, label_text=True):
    for i, (s, e, name) in enumerate(spans):
        ax.broken_barh(
            [(s / fps, (e - s) / fps)],
            (0, 1),
            facecolors=colours[i % len(colours)],
            edgecolor="white",
            linewidth=0.8,
        )
        if label_text and name:
            ax.text(
                (s + (e - s) / 2) / fps,
                0.5,
                str(name),
                ha="center",
                va="center",
                fontsize=7,
                clip_on=True,
            )


def plot_curve(
    path,
    x,
    y,
    cuts,
    *,
    fps: float = 1.0,
    n_frames: int | None = None,
    truth=None,
    threshold: float | None = None,
    title: str = "",
    ylabel: str = "score",
    extra=(),
) -> None:
    """Write a PNG: curve ``y`` over frames ``x``, vertical lines at ``cuts``, segment bars.

    Parameters
    ----------
    path : str or Path
        Output PNG.
    x : array_like, shape (m,)
        Frame of each curve value (e.g. window centres).
    y : array_like, shape (m,)
    cuts : sequence of int
        Detected cut frames.
    fps : float
        For the seconds axis.
    n_frames : int, optional
        Length of the recording (default: last x).
    truth : sequence of (start, end, label), optional
        Human segments (0-based, end exclusive), drawn as a coloured bar per segment, the
        same label in the same colour.
    threshold : float, optional
        Drawn as a dashed horizontal line.
    extra : sequence of (x, y, label)
        Further curves, drawn thin and grey behind the main one.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    n = int(n_frames if n_frames is not None else (x[-1] + 1 if x.size else 1))
    cuts = [int(c) for c in cuts]
    rows = 3 if truth else 2
    fig, axes = plt.subplots(
        rows,
        1,
        figsize=(11, 2.2 + 0.7 * rows),
        sharex=True,
        gridspec_kw={"height_ratios": [4] + [0.7] * (rows - 1)},
    )
    ax = axes[0]
    for ex, ey, elabel in extra:
        ax.plot(np.asarray(ex, dtype=float) / fps, ey, color="0.6", lw=0.8, label=elabel)
    ax.plot(x / fps, y, color="#1f77b4", lw=1.2, label=ylabel)
    if threshold is not None:
        ax.axhline(threshold, color="grey", ls="--", lw=0.8, label="threshold")
    for i, c in enumerate(cuts):
        ax.axvline(c / fps, color="#d62728", lw=1.0, label="detected cut" if i == 0 else None)
    if truth:
        for i, (s, _, _) in enumerate(truth[1:]):
            ax.axvline(
                s / fps, color="black", lw=0.8, ls=":", label="human cut" if i == 0 else None
            )
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.legend(loc="upper right", fontsize=7, ncol=4)
    palette = plt.get_cmap("tab20").colors
    b = [0] + cuts + [n]
    detected = [(s, e, "") for s, e in zip(b[:-1], b[1:]) if e > s]
    _bars(axes[1], detected, palette[::2], fps, label_text=False)
    axes[1].set_ylabel("detected", rotation=0, ha="right", va="center", fontsize=8)
    if truth:
        names = sorted({str(t[2]) for t in truth})
        colour = {nm: palette[(2 * i + 1) % len(palette)] for i, nm in enumerate(names)}
        _bars(
            axes[2],
            [(s, e, str(lab)) for s, e, lab in truth],
            [colour[str(t[2])] for t in truth],
            fps,
        )
        axes[2].set_ylabel("human", rotation=0, ha="right", va="center", fontsize=8)
    for a in axes[1:]:
        a.set_yticks([])
        a.set_ylim(0, 1)
    axes[-1].set_xlim(0, n / fps)
    axes[-1].set_xlabel("time (s)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
