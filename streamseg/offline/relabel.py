"""(H)ACA on a window of buffered features, for the daemon's relabelling worker.

:func:`relabel_window` is safe to call from a worker thread: it is pure (no shared state) and
its numba kernels release the GIL. While it runs, BLAS is limited to one thread process-wide
(threadpoolctl, when installed), so run one relabelling at a time. :func:`warmup` compiles
(or loads from cache) the kernels so the first window does not pay for it.

The number of actions is found per window when ``ACAConfig.n_clusters`` is None
(:func:`streamseg.offline.model_selection.fit_aca`).
Frames with NaN (lost markers) are left out of the fit and take their neighbours' label; a
window with nothing to cluster (too short, still, no finite frame) is one segment of one
label.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from streamseg.config import ACAConfig
from streamseg.exceptions import ParameterError
from streamseg.offline.model_selection import fit_aca


@dataclass(frozen=True)
class WindowSegmentation:
    """Segments of one window in absolute frames (0-based, end exclusive).

    Attributes
    ----------
    start, end : int
        The window covers frames ``start..end-1``.
    segments : list of (start, end, label)
        ACA segments tiling the window; labels are cluster ids kept consistent with the
        previous window's (a segment boundary between two segments of one label is a cycle
        boundary inside one action).
    n_clusters : int
        The number of actions the fit used (found or given; 0: unknown).
    next_id : int
        The stream's next unused id (ids are never reused; see
        :mod:`streamseg.offline.identity`); 0 outside the daemon.
    memory : ExemplarMemory or None
        The stream's exemplar memory after this revision (daemon, when turned on;
        :mod:`streamseg.offline.label_memory`).
    """

    start: int
    end: int
    segments: list
    n_clusters: int = 0
    next_id: int = 0
    memory: object = None

    def frame_labels(self) -> np.ndarray:
        """(end - start,) int64 label of every frame of the window."""
        out = np.empty(self.end - self.start, dtype=np.int64)
        for s, e, lab in self.segments:
            out[s - self.start : e - self.start] = lab
        return out


def match_labels(new_labels, old_labels, used=(), new_ids=None) -> dict:
    """Map new cluster ids onto old ones by the Hungarian matching of their frame overlap.

    Parameters
    ----------
    new_labels, old_labels : (n_overlap,) int arrays
        Labels of the same frames in the new and the previous window.
    used : iterable of int
        Ids the previous window used; new clusters left unmatched get the smallest ids that
        are in neither ``used`` nor the matched ids, so they never collide with old ids.
    new_ids : iterable of int, optional
        Every id of the new window, including clusters that occur only outside the overlap
        (they get fresh ids too); default: the ids in ``new_labels``.

    Returns
    -------
    dict new id -> consistent id, for every id in ``new_labels`` and ``new_ids``.
    """
    new_labels = np.asarray(new_labels, dtype=np.int64)
    old_labels = np.asarray(old_labels, dtype=np.int64)
    seen = np.unique(new_labels)
    new_ids = np.union1d(
        seen, np.asarray(list(new_ids) if new_ids is not None else [], dtype=np.int64)
    )
    mapping = {}
    if old_labels.size:
        old_ids = np.unique(old_labels)
        C = np.zeros((new_ids.size, old_ids.size))
        np.add.at(
            C, (np.searchsorted(new_ids, new_labels), np.searchsorted(old_ids, old_labels)), 1
        )
        for r, c in zip(*linear_sum_assignment(-C), strict=True):
            if C[r, c] > 0:
                mapping[int(new_ids[r])] = int(old_ids[c])
    taken = set(int(u) for u in used) | set(mapping.values())
    fresh = (i for i in range(len(taken) + new_ids.size + 1) if i not in taken)
    for u in new_ids:
        if int(u) not in mapping:
            mapping[int(u)] = next(fresh)
    return mapping


def relabel_window(
    features,
    *,
    start_frame: int,
    fps: float,
    config: ACAConfig,
    previous: WindowSegmentation | None = None,
) -> WindowSegmentation:
    """Run (H)ACA on a window and keep its cluster ids consistent with ``previous``.

    Parameters
    ----------
    features : (n, d) array
        Feature frames ``start_frame .. start_frame + n - 1`` (e.g. quaternion features).
    start_frame : int
        Absolute index of the first row.
    fps : float
        Frame rate, to turn the config's seconds into frames.
    config : ACAConfig
    previous : WindowSegmentation, optional
        The previous window's result; clusters are matched over the frames both windows cover.

    Returns
    -------
    WindowSegmentation in absolute frames (the caller keeps the revision number).
    """
    if not isinstance(config, ACAConfig):
        raise ParameterError(f"config={config!r} is invalid: expected an ACAConfig")
    if not (isinstance(fps, (int, float)) and fps > 0):
        raise ParameterError(f"fps={fps!r} is invalid: expected a frame rate > 0")
    X = np.asarray(features, dtype=np.float64)
    if X.ndim != 2 or X.shape[0] == 0:
        raise ParameterError(f"features must be a non-empty (n, d) array, got {X.shape}")
    start = int(start_frame)
    n = X.shape[0]
    model = fit_aca(X, config, fps)
    labels = model.labels_
    used = ()
    old_part = np.zeros(0, dtype=np.int64)
    new_part = old_part
    if previous is not None:
        used = {lab for _, _, lab in previous.segments}
        lo = max(start, previous.start)
        hi = min(start + n, previous.end)
        if hi > lo:
            old_part = previous.frame_labels()[lo - previous.start : hi - previous.start]
            new_part = labels[lo - start : hi - start]
    mapping = (
        match_labels(new_part, old_part, used, new_ids=np.unique(labels))
        if previous is not None
        else {int(u): int(u) for u in np.unique(labels)}
    )
    segments = [(s + start, e + start, mapping[lab]) for s, e, lab in model.segments_]
    return WindowSegmentation(start, start + n, segments, model.n_clusters_)


def warmup() -> None:
    """Compile or load the ACA kernels (call once at daemon start, off the hot path)."""
    from streamseg.offline.aca import ACAEngine

    x = np.array([0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 1.0])
    ACAEngine(2, 2, 3, n_init=1, kernel="equality", random_state=0).fit(x)
    ACAEngine(2, 2, 3, n_init=1, kernel="gaussian", sigma=1.0, random_state=0).fit(x)
    ACAEngine(
        2,
        2,
        3,
        n_init=1,
        kernel="gaussian",
        sigma=1.0,
        k_reduce=2,  # k-means kernel too
        random_state=0,
    ).fit(np.repeat(x, 3)[:, None])
