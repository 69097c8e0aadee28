"""Picture of the sets and repetitions found (matplotlib imported only when called)."""

from __future__ import annotations

import numpy as np


def title(segmenter, sets, name: str = "") -> str:
    """The count, or why there is none (never a count of a take without a set)."""
    head = f"{name}: " if name else ""
    if not sets:
        return f"{head}no set of repetitions ({segmenter.reason_})"
    counts = ", ".join(str(st["count"]) for st in sets)
    return (
        f"{head}{sum(st['count'] for st in sets)} repetitions in {len(sets)} "
        f"set{'' if len(sets) == 1 else 's'} ({counts})"
    )


def _motion(features, fps):
    """The pose's two main directions of change over the take, each at unit spread."""
    from scipy.signal import butter, sosfiltfilt

    X = np.asarray(features, dtype=np.float64)
    if X.shape[0] > 12 and fps > 6:
        X = sosfiltfilt(butter(2, min(3.0, 0.4 * fps), fs=fps, output="sos"), X, axis=0)
    X = X - X.mean(axis=0)
    if not np.any(X):
        return np.zeros((X.shape[0], 1))
    _, _, vt = np.linalg.svd(X, full_matrices=False)
    Y = X @ vt[: min(2, vt.shape[0])].T
    sd = Y.std(axis=0)
    return Y / np.where(sd > 0, sd, 1.0)


def measures(st) -> list:
    """Per repetition of set ``st`` (``segment --method rep`` JSON) ``(start, end, rom_deg,
    likeness)``; None where the counter has none."""
    return [(r["start"], r["end"], r.get("rom_deg"), r.get("likeness")) for r in st["repetitions"]]


def _json_sets(segmenter) -> list:
    """A segmenter's sets as the JSON gives them (unlabelled)."""
    out = []
    for st in segmenter.sets_:
        n = len(st["repetitions"])
        per = zip(
            st["repetitions"], st.get("rom_deg") or [None] * n, st.get("likeness") or [None] * n
        )
        out.append(
            dict(
                st,
                label=None,
                repetitions=[
                    {"start": a, "end": b, "rom_deg": r, "likeness": k} for (a, b), r, k in per
                ],
            )
        )
    return out


def plot_repetitions(path, segmenter, sets=None, truth=None, title_file: str = "") -> None:
    """Write a PNG of :func:`figure_repetitions` (same parameters, ``path`` first)."""
    fig = figure_repetitions(segmenter, sets, truth, title_file)
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=90, bbox_inches="tight")  # the legend sits right of the axes
    plt.close(fig)


def figure_repetitions(segmenter, sets=None, truth=None, title_file: str = ""):
    """A matplotlib figure: the motion with each set and repetition drawn, and the tempo.

    Top: the pose's two main directions of change (principal components of the counter's
    features, each scaled to unit spread), each set shaded in its colour and each
    repetition a band of its own, numbered. Bottom: seconds per repetition, one bar per
    repetition, so a set that slows down shows it, each bar marked with the repetition's
    range of motion (degrees of the set's most moving joint, right axis, a dot) and its
    likeness to the one before (in the bar, 0-1). A legend names every set (label, count,
    tempo, confidence, the joint whose range is shown).

    Parameters
    ----------
    segmenter : RepetitionSegmenter
        Fitted.
    sets : list of dict, optional
        ``segment --method rep`` JSON "sets" (default: the segmenter's, unlabelled).
    truth : list of (start, end), optional
        True repetitions: their boundaries drawn as grey dashed lines.
    title_file : str
        Name shown in the title.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.patches import Patch
    except ImportError as err:  # plotting is an optional extra
        from streamseg.exceptions import ParameterError

        raise ParameterError("--plot needs matplotlib: pip install 'streamseg[plot]'") from err
    fps = float(segmenter.fps_)
    if sets is None:
        sets = _json_sets(segmenter)
    n = int(segmenter.n_frames_)
    t = np.arange(n) / fps
    fig, (ax1, ax2) = plt.subplots(
        2, 1, figsize=(12, 6.5), sharex=True, gridspec_kw={"height_ratios": [2.2, 1]}
    )
    if n:
        Y = _motion(segmenter.features_, fps)
        for j in range(Y.shape[1]):
            ax1.plot(
                t, Y[:, j], lw=1.0, color=("0.15", "0.55")[j], label=f"pose, main direction {j + 1}"
            )
    handles = []
    ax3 = None
    for i, st in enumerate(sets):
        colour = f"C{i % 10}"
        per = measures(st)
        reps = [(a, b) for a, b, _, _ in per]
        for k, (a, b, rom, like) in enumerate(per):
            ax1.axvspan(a / fps, b / fps, color=colour, alpha=0.28 if k % 2 == 0 else 0.14, lw=0)
            ax1.axvline(a / fps, color=colour, lw=1.2)
            ax1.text(
                (a + b) / 2 / fps,
                0.98,
                str(k + 1),
                transform=ax1.get_xaxis_transform(),
                ha="center",
                va="top",
                fontsize=7,
                color=colour,
            )
            ax2.bar(
                (a + b) / 2 / fps,
                (b - a) / fps,
                width=0.9 * (b - a) / fps,
                color=colour,
                alpha=0.75,
            )
            if like is not None:
                ax2.text(
                    (a + b) / 2 / fps,
                    0.02,
                    f"{like:.2f}",
                    rotation=90,
                    ha="center",
                    va="bottom",
                    fontsize=6,
                    transform=ax2.get_xaxis_transform(),
                )
            if rom is not None:
                if ax3 is None:
                    ax3 = ax2.twinx()
                ax3.plot((a + b) / 2 / fps, rom, "o", color=colour, ms=4, mec="0.1", mew=0.5)
        if reps:
            ax1.axvline(reps[-1][1] / fps, color=colour, lw=1.2)
        label = "" if st.get("label") is None else f" (action {st['label']})"
        joint = f", range of {st['rom_joint']}" if st.get("rom_joint") else ""
        handles.append(
            Patch(
                color=colour,
                alpha=0.5,
                label=f"set {i + 1}{label}: {st['count']} repetitions, "
                f"{st['tempo_min_s']:.2f}-{st['tempo_max_s']:.2f} s each, "
                f"confidence {st['confidence']:.2f}{joint}",
            )
        )
    for k, (a, _) in enumerate(truth or []):
        for ax in (ax1, ax2):
            ax.axvline(
                a / fps,
                color="0.5",
                ls="--",
                lw=0.8,
                label="true boundaries" if (k == 0 and ax is ax1) else None,
            )
    line_handles, _ = ax1.get_legend_handles_labels()
    ax1.legend(
        handles=line_handles + handles,
        fontsize=7,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        borderaxespad=0.0,
    )
    ax1.set_ylabel("pose change (unit spread)")
    ax2.set_ylabel("seconds per repetition\n(in the bar: likeness)")
    if ax3 is not None:
        ax3.set_ylabel("range of motion (deg, dots)")
        top = max(y for ln in ax3.get_lines() for y in ln.get_ydata())
        ax3.set_ylim(0, 1.15 * top if top > 0 else 1.0)
    ax2.set_xlabel("seconds")
    if not sets:
        ax2.text(
            0.5,
            0.5,
            segmenter.reason_,
            transform=ax2.transAxes,
            ha="center",
            va="center",
            fontsize=8,
        )
    ax1.set_xlim(0, max(n / fps, 1e-3))
    fig.suptitle(title(segmenter, sets, title_file), fontsize=10)
    fig.tight_layout()
    return fig
