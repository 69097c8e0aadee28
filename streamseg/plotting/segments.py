"""Picture of a clustering segmentation ((H)ACA): the found actions, the human ones, and the
motion they were found in."""

from __future__ import annotations

import numpy as np

#: principal components of the features drawn under the bands
N_COMPONENTS = 3


def _runs(labels):
    """``(start, end, label)`` runs of equal values in a frame-label array."""
    labels = np.asarray(labels)
    b = np.concatenate([[0], np.flatnonzero(labels[1:] != labels[:-1]) + 1, [len(labels)]])
    return [(int(s), int(e), labels[s].item()) for s, e in zip(b[:-1], b[1:], strict=True)]


def _band(ax, runs, fps, colour, name_of, min_share=0.04):
    """Coloured spans, each named in place when wide enough to hold its name."""
    total = max((e for _, e, _ in runs), default=1)
    for s, e, lab in runs:
        if lab is None or (isinstance(lab, (int, np.integer)) and lab < 0):
            continue  # unlabelled frames
        ax.axvspan(s / fps, e / fps, color=colour(lab), lw=0)
        ax.axvline(s / fps, color="k", lw=0.5)
        if (e - s) / total >= min_share:
            ax.text(
                (s + e) / 2 / fps,
                0.5,
                name_of(lab),
                ha="center",
                va="center",
                fontsize=8,
                transform=ax.get_xaxis_transform(),
                clip_on=True,
            )
    ax.set_yticks([])


def components(features, k: int = N_COMPONENTS):
    """The first ``k`` principal components of ``features`` (n, d) and the share of the
    variance each explains (NaN rows stay NaN)."""
    X = np.asarray(features, dtype=float)
    ok = np.isfinite(X).all(axis=1)
    out = np.full((X.shape[0], 0), np.nan)
    if ok.sum() < 2 or X.shape[1] == 0:
        return out, np.zeros(0)
    Xc = X[ok] - X[ok].mean(axis=0)
    _, sv, vt = np.linalg.svd(Xc, full_matrices=False)
    k = min(k, vt.shape[0])
    out = np.full((X.shape[0], k), np.nan)
    out[ok] = Xc @ vt[:k].T
    var = sv**2
    return out, var[:k] / var.sum() if var.sum() > 0 else np.zeros(k)


def segments_figure(
    features,
    segments,
    *,
    fps=1.0,
    truth=None,
    truth_names=None,
    matching=None,
    method="HACA",
    title="",
):
    """The figure :func:`plot_segments` writes (returned for callers that add to it).

    Parameters
    ----------
    features : (n, d) array
        The features the method clustered; their first principal components are drawn.
    segments : list of (start, end, label)
        The method's segments, labels are cluster ids.
    fps : float
        To label the time axis in seconds.
    truth : (n,) int array, optional
        Human frame labels (indices into ``truth_names``; -1: unlabelled), a second band.
    truth_names : list of str, optional
        The human actions' names: each run of the truth band is named.
    matching : dict, optional
        Cluster id -> human label index: a matched cluster takes its action's colour and is
        named after it.
    method : str
        The method's name for the band ("ACA" or "HACA").
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    X = np.asarray(features, dtype=float)
    n = X.shape[0]
    matching = matching or {}
    names = list(truth_names or [])
    cmap = plt.get_cmap("tab10")
    n_names = len(names)

    def colour(cluster):  # matched clusters in their action's colour, others after those
        return cmap(matching.get(cluster, n_names + cluster) % 10)

    def cluster_name(cluster):
        hit = matching.get(cluster)
        return f"id {cluster}" + (f" ({names[hit]})" if hit is not None and hit < n_names else "")

    rows = 3 if truth is not None else 2
    fig, axes = plt.subplots(
        rows,
        1,
        figsize=(12, 1.2 * rows + 2.4),
        sharex=True,
        gridspec_kw={"height_ratios": [1] * (rows - 1) + [3]},
    )
    merged = []  # consecutive segments of one cluster are one action: named once
    for s, e, lab in segments:
        if merged and merged[-1][2] == int(lab) and merged[-1][1] == int(s):
            merged[-1] = (merged[-1][0], int(e), int(lab))
        else:
            merged.append((int(s), int(e), int(lab)))
    _band(axes[0], merged, fps, colour, cluster_name)
    for s, _e, _lab in segments:  # the segments inside an action, thin
        axes[0].axvline(int(s) / fps, color="k", lw=0.3, alpha=0.5)
    axes[0].set_ylabel(method, rotation=0, ha="right", va="center")
    if truth is not None:
        _band(
            axes[1],
            _runs(truth),
            fps,
            lambda lab: cmap(int(lab) % 10),
            lambda lab: names[lab] if lab < n_names else str(lab),
        )
        axes[1].set_ylabel("human", rotation=0, ha="right", va="center")
    pcs, share = components(X)
    t = np.arange(n) / fps
    for i in range(pcs.shape[1]):
        axes[-1].plot(t, pcs[:, i], lw=0.7, label=f"PC{i + 1} ({share[i]:.0%} of the variance)")
    if pcs.shape[1]:
        axes[-1].legend(loc="upper right", fontsize=8)
    axes[-1].set_ylabel(f"features ({X.shape[1]} columns),\nprincipal components", fontsize=8)
    axes[-1].set_xlabel("time (s)")
    axes[-1].set_xlim(0, n / fps)
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_segments(path, features, segments, **kwargs) -> None:
    """Write a PNG: the method's segments as a band (each named), the human labels below it
    when given (each action named), and the features' first principal components. Keyword
    arguments: :func:`segments_figure`'s."""
    import matplotlib.pyplot as plt

    fig = segments_figure(features, segments, **kwargs)
    fig.savefig(path, dpi=100)
    plt.close(fig)
