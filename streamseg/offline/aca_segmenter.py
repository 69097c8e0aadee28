"""(H)ACA as an estimator of the common convention, with the number of actions found."""

from __future__ import annotations

import numpy as np

from streamseg.config import ACAConfig
from streamseg.exceptions import ParameterError
from streamseg.offline.model_selection import fit_aca
from streamseg.segments import Estimator, segments_from_labels


class ACASegmenter(Estimator):
    """Temporal clustering into actions: HACA by default, K found unless the config gives it.

    Parameters
    ----------
    config : ACAConfig or None
        Lengths in seconds; ``n_clusters=None`` (default) finds K in ``[2, k_max]``
        (:mod:`streamseg.offline.model_selection`).
    fps : float
        Frame rate of the features given to :meth:`fit`, converting seconds to frames.

    Attributes
    ----------
    labels_ : ndarray of int64, shape (n_frames,)
        Action id of every frame.
    segments_ : list of Segment
        Runs of one action id (what :meth:`predict` returns).
    pieces_ : list of (start, end, label)
        The model's own segments (ACA tiles an action with several segments of at most
        ``max_len_s``).
    n_clusters_ : int
        K used (found or given); 1 when the data held nothing to cluster.
    k_scores_ : dict of int -> float
        Silhouette of every K tried (empty when K was given).
    objective_ : float
    note_ : str
        Why the data were not clustered ("" when they were).

    Examples
    --------
    >>> from streamseg.offline import ACASegmenter
    >>> segments = ACASegmenter(fps=120.0).fit_predict(features)  # doctest: +SKIP
    """

    def __init__(self, config: ACAConfig | None = None, fps: float = 120.0):
        self.config = ACAConfig() if config is None else config
        if not (np.isscalar(fps) and np.isfinite(fps) and float(fps) > 0):
            raise ParameterError(
                f"fps={fps!r} is invalid: expected the frame rate (> 0) of "
                "the features given to fit"
            )
        self.fps = float(fps)

    def fit(self, X) -> ACASegmenter:
        """Cluster ``X``, shape (n_frames, n_features) (a Recording: its LOF features).

        Rows with a non-finite value are allowed: they take the label of the frame before.
        """
        if hasattr(X, "positions") and hasattr(X, "skeleton"):
            from streamseg.offline.lof import lof_features

            X = lof_features(X)
        fitted = fit_aca(X, self.config, self.fps)
        labels = np.asarray(fitted.labels_, dtype=np.int64)
        self.labels_ = labels
        self.segments_ = segments_from_labels(labels)
        self.pieces_ = [tuple(int(v) for v in s) for s in fitted.segments_]
        self.n_clusters_ = int(fitted.n_clusters_)
        self.k_scores_ = {int(k): float(v) for k, v in fitted.scores_.items()}
        self.objective_ = float(fitted.objective_)
        self.note_ = fitted.reason
        return self
