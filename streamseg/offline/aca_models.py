"""ACA and HACA as estimators of the common convention: ``(config=None, fps=120.0)``.

:class:`ACA` is one-level Aligned Cluster Analysis (Zhou et al. 2008), :class:`HACA` the
two-level one (Zhou et al. 2013); both take an :class:`~streamseg.config.ACAConfig` (lengths
in seconds, frozen, validated once) and the frame rate of what ``fit`` is given, as
:class:`~streamseg.offline.LOFSegmenter` and the other estimators do
(:class:`streamseg.segments.Estimator`). ``ACA`` ignores the config's ``hierarchical`` and
HACA fields; ``HACA`` uses them. With ``n_clusters=None`` the number of actions is found
(:mod:`streamseg.offline.model_selection`). The engines they run, with lengths in frames as
the papers state the algorithms, are :class:`~streamseg.offline.aca.ACAEngine` and
:class:`~streamseg.offline.haca.HACAEngine`.
"""

from __future__ import annotations

import inspect
from dataclasses import replace

import numpy as np

from streamseg.config import ACAConfig
from streamseg.exceptions import ParameterError
from streamseg.segments import Estimator

_OLD = (
    "n_clusters",
    "min_len_frames",
    "max_len_frames",
    "n_init",
    "max_iter",
    "kernel",
    "sigma",
    "init",
    "k_reduce",
    "reduce_cap",
    "k_frame",
    "random_state",
    "fine_clusters",
    "fine_min_len_frames",
    "fine_max_len_frames",
    "coarse_kernel",
)


class _ACAModel(Estimator):
    _hierarchical = False
    # what help() and inspect show: the convention; *args and **old only catch old calls
    __signature__ = inspect.Signature(
        [
            inspect.Parameter("config", inspect.Parameter.POSITIONAL_OR_KEYWORD, default=None),
            inspect.Parameter("fps", inspect.Parameter.POSITIONAL_OR_KEYWORD, default=120.0),
            inspect.Parameter("n_jobs", inspect.Parameter.KEYWORD_ONLY, default=1),
        ]
    )

    def __init__(
        self, config: ACAConfig | None = None, fps: float = 120.0, *args, n_jobs: int = 1, **old
    ):
        name = type(self).__name__
        if args or old or not (config is None or isinstance(config, ACAConfig)):
            raise ParameterError(
                f"{name}(n_clusters, min_len_frames, max_len_frames, ...) is the old call: "
                f"give {name}(ACAConfig(n_clusters=..., min_len_s=..., max_len_s=..., ...), "
                f"fps=...) with lengths in seconds, or use streamseg.offline.{name}Engine "
                "for lengths in frames"
                + (f" (unknown keywords: {', '.join(sorted(old))})" if set(old) - set(_OLD) else "")
            )
        if not (np.isscalar(fps) and np.isfinite(fps) and float(fps) > 0):
            raise ParameterError(
                f"fps={fps!r} is invalid: expected the frame rate (> 0) of "
                "the features given to fit"
            )
        if not (n_jobs == -1 or (isinstance(n_jobs, int) and n_jobs >= 1)):
            raise ParameterError(f"n_jobs={n_jobs!r} is invalid: expected -1 or an integer >= 1")
        self.config = ACAConfig() if config is None else config
        self.fps = float(fps)
        self.n_jobs = n_jobs

    def fit(self, X):
        """Cluster ``X``, shape (n_frames, n_features): rows with a non-finite value take the
        label of the frame before them (:func:`~streamseg.offline.model_selection.fit_aca`).
        """
        from streamseg.offline.model_selection import fit_aca

        config = replace(self.config, hierarchical=self._hierarchical)
        fitted = fit_aca(X, config, self.fps, n_jobs=self.n_jobs)
        self.labels_ = np.asarray(fitted.labels_, dtype=np.int64)
        self.segments_ = [tuple(int(v) for v in s) for s in fitted.segments_]
        self.n_clusters_ = int(fitted.n_clusters_)
        self.k_scores_ = {int(k): float(v) for k, v in fitted.scores_.items()}
        self.objective_ = float(fitted.objective_)
        self.note_ = fitted.reason
        self._engine_attributes(fitted.model)
        return self

    def _engine_attributes(self, engine) -> None:
        if engine is not None:
            self.restart_objectives_ = engine.restart_objectives_
            self.n_iter_ = engine.n_iter_


_ATTRIBUTES = """
    Parameters
    ----------
    config : ACAConfig or None
        Lengths in seconds, the number of actions (None: found in ``[2, k_max]``), restarts,
        kernel, reduction and seed; None: its defaults.
    fps : float
        Frame rate of the features given to :meth:`fit`, converting seconds to frames.
    n_jobs : int
        Threads running each fit's restarts (-1: one per CPU); the result does not depend
        on it.

    Attributes
    ----------
    labels_ : ndarray of int64, shape (n_frames,)
    segments_ : list of (start, end, label)
        The model's segments (0-based, end exclusive), tiling the frames; :meth:`predict`
        returns them as :class:`~streamseg.segments.Segment`.
    n_clusters_ : int
        K used (found or given); 1 when the data held nothing to cluster.
    k_scores_ : dict of int -> float
        Silhouette of every K tried (empty when K was given).
    objective_ : float
        Eq. 5 of the kept restart (of the coarse level for HACA).
    note_ : str
        Why the data were not clustered ("" when they were).
"""


class ACA(_ACAModel):
    __doc__ = (
        """One-level Aligned Cluster Analysis (``config.hierarchical`` is ignored).
"""
        + _ATTRIBUTES
        + """    restart_objectives_ : ndarray, shape (n_init,)
    n_iter_ : int
        Coordinate-descent steps of the kept restart.

    Examples
    --------
    >>> from streamseg.config import ACAConfig
    >>> from streamseg.offline import ACA
    >>> cfg = ACAConfig(n_clusters=4, min_len_s=10, max_len_s=15, kernel="equality")
    >>> segments = ACA(cfg, fps=1.0).fit_predict(x)  # doctest: +SKIP
    """
    )


class HACA(_ACAModel):
    __doc__ = (
        """Two-level (hierarchical) ACA: primitives of ``config.fine_*``, then actions.
"""
        + _ATTRIBUTES
        + """    fine_segments_ : list of (start, end, label)
        The primitives (fine level) in frames.
    """
    )
    _hierarchical = True

    def _engine_attributes(self, engine) -> None:
        if engine is not None:
            self.fine_segments_ = engine.fine_segments_
