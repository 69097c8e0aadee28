"""Hierarchical ACA (Zhou, De la Torre & Hodgins, PAMI 2013): ACA at a fine level cuts the
sequence into short segments (motion primitives); those segments become the units of a second
ACA, so the coarse level aligns sequences of primitives instead of frames.

The coarse "frame" kernel is, by default, the DTAK between the primitives themselves;
``coarse_kernel="labels"`` uses instead the equality kernel on the primitives' cluster labels
(a primitive as a symbol, as in the paper's synthetic experiment). On CMU 86_01 the labels
are better (mean frame accuracy over 5 seeds 0.938 against 0.904), but on the held-out CMU
14_14 / 14_20 (6 actions) they are worse (0.773 / 0.697 against 0.863 / 0.856): with 10
primitive clusters for 6 actions many primitives are shared and the symbol loses what the
DTAK keeps. The default is therefore DTAK (``benchmarks/aca_mocap.py`` prints both).

Lengths of the coarse level are given in frames and converted to fine-segment units with the
mean fine-segment length (the coarse DP counts units, not frames).
"""

from __future__ import annotations

import numpy as np

from streamseg.exceptions import ParameterError
from streamseg.offline.aca import ACAEngine
from streamseg.offline.aca_init import kmeans, tiling_kernel
from streamseg.offline.dtak import _as_frames, frame_kernel
from streamseg.offline.reduction import reduce_frames
from streamseg.segments import Estimator


class HACAEngine(Estimator):
    """Two-level ACA with lengths in frames (the engine :class:`streamseg.offline.HACA` runs).

    Parameters
    ----------
    n_clusters, min_len_frames, max_len_frames : int
        Coarse level: number of actions and segment lengths in frames.
    fine_clusters, fine_min_len_frames, fine_max_len_frames : int
        Fine level: number of primitives and their lengths in frames.
    coarse_kernel : {"labels", "dtak"}
        Kernel between primitives at the coarse level (module docstring).
    n_init, max_iter, kernel, sigma, init, k_reduce, reduce_cap, n_jobs, random_state
        As in :class:`streamseg.offline.aca.ACAEngine` (``init`` applies to the fine level). The
        coarse level starts its first restart from the propagated initialization (eq. 10)
        with the fine labels as unit classes, the others from random ones.

    Attributes
    ----------
    labels_ : (n_frames,) int64
    segments_ : list of (start, end, label)
        Coarse segments in frames.
    fine_segments_ : list of (start, end, label)
        Fine segments in frames.
    objective_ : float
        Eq. 5 of the coarse level.
    """

    def __init__(
        self,
        n_clusters,
        min_len_frames,
        max_len_frames,
        *,
        fine_clusters=10,
        fine_min_len_frames=None,
        fine_max_len_frames=None,
        coarse_kernel="dtak",
        n_init=10,
        max_iter=50,
        kernel="gaussian",
        sigma=None,
        init="random",
        k_reduce=None,
        reduce_cap=20,
        n_jobs=1,
        random_state=None,
    ):
        self.n_clusters = n_clusters
        self.min_len_frames = min_len_frames
        self.max_len_frames = max_len_frames
        self.fine_clusters = fine_clusters
        self.fine_min_len_frames = fine_min_len_frames
        self.fine_max_len_frames = fine_max_len_frames
        self.coarse_kernel = coarse_kernel
        self.n_init = n_init
        self.max_iter = max_iter
        self.kernel = kernel
        self.sigma = sigma
        self.init = init
        self.k_reduce = k_reduce
        self.reduce_cap = reduce_cap
        self.n_jobs = n_jobs
        self.random_state = random_state

    def fit(self, X):
        """Segment ``X``: (n_frames, d) features."""
        ((_, fitted),) = self.fit_each(X, [self.n_clusters])
        self.__dict__.update(fitted.__dict__)
        return self

    def fit_each(self, X, n_clusters):
        """Fit the fine level once, then the coarse level for each K of ``n_clusters``.

        The fine level (primitives) does not depend on the number of actions, so a search
        over K pays for it once. Each coarse fit starts from the same random state, so
        ``fit_each(X, [k])`` gives exactly ``HACAEngine(k, ...).fit(X)``.

        Returns
        -------
        list of (k, fitted HACA)
        """
        import copy

        X = _as_frames(X)
        n = X.shape[0]
        fmin = self.fine_min_len_frames
        fmin = max(1, self.min_len_frames // 4) if fmin is None else fmin
        fmax = self.fine_max_len_frames
        fmax = max(fmin, self.min_len_frames) if fmax is None else fmax
        if self.coarse_kernel not in ("labels", "dtak"):
            raise ParameterError(
                f"coarse_kernel={self.coarse_kernel!r} is invalid: expected 'labels' or 'dtak'"
            )
        if self.kernel not in ("gaussian", "equality"):
            raise ParameterError(
                f"kernel={self.kernel!r} is invalid: expected 'gaussian' or 'equality'"
            )
        rng = np.random.default_rng(self.random_state)
        if self.k_reduce is not None:
            Xr, (rs, re), classes = reduce_frames(X, self.k_reduce, self.reduce_cap, rng)
        else:
            Xr, rs, re = X, np.arange(n), np.arange(1, n + 1)
            classes = kmeans(X, 20, rng) if self.init == "propagated" else None
        nr = Xr.shape[0]
        # the equality kernel as int8 (exact 0/1): both levels read it, never widened
        K = np.ascontiguousarray(
            frame_kernel(Xr, kernel=self.kernel, sigma=self.sigma, binary_dtype=np.int8)
        )
        scale = nr / n  # reduced frames per frame
        fine = ACAEngine(
            self.fine_clusters,
            max(1, round(fmin * scale)),
            max(1, round(fmax * scale)),
            n_init=self.n_init,
            max_iter=self.max_iter,
            kernel="precomputed",
            init=self.init,
            n_jobs=self.n_jobs,
            random_state=rng,
        ).fit(K, frame_classes=classes)
        fs = np.array([s for s, _, _ in fine.segments_], dtype=np.int64)
        fe = np.array([e for _, e, _ in fine.segments_], dtype=np.int64)
        fine_labels = np.array([lab for _, _, lab in fine.segments_])
        if self.coarse_kernel == "labels":
            T = (fine_labels[:, None] == fine_labels[None, :]).astype(np.float64)
        else:
            T = tiling_kernel(K, fs, fe)
        per_unit = n / fs.size  # frames per fine segment
        cmax = max(1, round(self.max_len_frames / per_unit))
        cmin = min(cmax, max(1, round(self.min_len_frames / per_unit)))
        # units -> reduced frames -> frames
        unit_frame_start = rs[fs]
        unit_frame_end = re[fe - 1]
        fine_segments = [
            (int(unit_frame_start[i]), int(unit_frame_end[i]), int(lab))
            for i, (_, _, lab) in enumerate(fine.segments_)
        ]
        out = []
        for k in n_clusters:
            # first coarse restart: eq. 10 propagation over the primitives' labels
            coarse = ACAEngine(
                k,
                cmin,
                cmax,
                n_init=self.n_init,
                max_iter=self.max_iter,
                kernel="precomputed",
                init="propagated",
                n_jobs=self.n_jobs,
                random_state=copy.deepcopy(rng),
            ).fit(T, frame_classes=fine_labels)
            fitted = copy.copy(self)
            fitted.n_clusters = k
            fitted.fine_segments_ = fine_segments
            fitted.segments_ = [
                (int(unit_frame_start[s]), int(unit_frame_end[e - 1]), int(lab))
                for s, e, lab in coarse.segments_
            ]
            labels = np.empty(n, dtype=np.int64)
            for s, e, lab in fitted.segments_:
                labels[s:e] = lab
            fitted.labels_ = labels
            fitted.objective_ = coarse.objective_
            fitted.fine_objective_ = fine.objective_
            out.append((k, fitted))
        return out
