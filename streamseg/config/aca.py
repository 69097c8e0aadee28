"""Aligned Cluster Analysis relabelling."""

from __future__ import annotations

from dataclasses import dataclass

from streamseg.config._base import _check


@dataclass(frozen=True)
class ACAConfig:
    """Aligned Cluster Analysis relabelling; lengths in seconds.

    Why each default: ``docs/decisions.md`` (Labels).

    Attributes
    ----------
    n_clusters : int or None
        Number of actions; None: per window, the best silhouette in ``[2, k_max]``.
    k_max : int
        Largest number of actions tried when ``n_clusters`` is None.
    min_len_s, max_len_s : float
        Segment lengths (one or a few cycles; an action's run is several segments).
    kernel : {"gaussian", "equality"}
        Frame kernel; "equality" is the paper's sigma -> 0 limit for discrete data.
    sigma : float or None
        Gaussian bandwidth in feature units; None: ``streamseg.offline.dtak.default_sigma``.
    n_init : int
        Random restarts; the lowest objective wins.
    max_iter : int
        Cap on coordinate-descent steps per restart.
    init : {"random", "propagated"}
        Initialization of the first restart (section 4.2); the others are random.
    k_reduce : int or None
        Temporal reduction into this many k-means frame classes (section 4.1); None = off.
    reduce_cap : float
        At most this many seconds of consecutive same-class frames become one reduced frame.
    hierarchical : bool
        Two-level HACA (the default) instead of one-level ACA.
    fine_clusters : int
        HACA fine level: number of primitives.
    fine_min_len_s, fine_max_len_s : float
        HACA fine level: primitive lengths in seconds.
    coarse_kernel : {"labels", "dtak"}
        HACA coarse level: primitives compared by DTAK or by equal cluster labels.
    random_state : int or None
        Seed (fixed by default so a window gives the same answer twice).
    """

    n_clusters: int | None = None
    k_max: int = 8
    min_len_s: float = 0.5
    max_len_s: float = 2.0
    kernel: str = "gaussian"
    sigma: float | None = None
    n_init: int = 10
    max_iter: int = 50
    init: str = "random"
    k_reduce: int | None = 20
    reduce_cap: float = 1 / 6
    hierarchical: bool = True
    fine_clusters: int = 10
    fine_min_len_s: float = 1 / 12
    fine_max_len_s: float = 0.25
    coarse_kernel: str = "dtak"
    random_state: int | None = 0

    def __post_init__(self):
        def is_int(v):
            return isinstance(v, int) and not isinstance(v, bool)

        _check(
            "n_clusters",
            self.n_clusters,
            self.n_clusters is None or (is_int(self.n_clusters) and self.n_clusters >= 1),
            "None or an integer >= 1",
        )
        _check("k_max", self.k_max, is_int(self.k_max) and self.k_max >= 2, "an integer >= 2")
        _check(
            "min_len_s",
            self.min_len_s,
            isinstance(self.min_len_s, (int, float)) and self.min_len_s > 0,
            "a length > 0 seconds",
        )
        _check(
            "max_len_s",
            self.max_len_s,
            isinstance(self.max_len_s, (int, float)) and self.max_len_s >= self.min_len_s,
            f"a length >= min_len_s={self.min_len_s} seconds",
        )
        _check(
            "kernel",
            self.kernel,
            self.kernel in ("gaussian", "equality"),
            "'gaussian' or 'equality'",
        )
        _check(
            "sigma",
            self.sigma,
            self.sigma is None or (isinstance(self.sigma, (int, float)) and self.sigma > 0),
            "None or a number > 0",
        )
        _check("n_init", self.n_init, is_int(self.n_init) and self.n_init >= 1, "an integer >= 1")
        _check(
            "max_iter",
            self.max_iter,
            is_int(self.max_iter) and self.max_iter >= 1,
            "an integer >= 1",
        )
        _check("init", self.init, self.init in ("random", "propagated"), "'random' or 'propagated'")
        _check(
            "k_reduce",
            self.k_reduce,
            self.k_reduce is None or (is_int(self.k_reduce) and self.k_reduce >= 2),
            "None or an integer >= 2",
        )
        _check(
            "reduce_cap",
            self.reduce_cap,
            isinstance(self.reduce_cap, (int, float)) and self.reduce_cap > 0,
            "a duration > 0 seconds",
        )
        _check(
            "hierarchical", self.hierarchical, isinstance(self.hierarchical, bool), "True or False"
        )
        _check(
            "fine_clusters",
            self.fine_clusters,
            is_int(self.fine_clusters) and self.fine_clusters >= 1,
            "an integer >= 1",
        )
        _check(
            "fine_min_len_s",
            self.fine_min_len_s,
            isinstance(self.fine_min_len_s, (int, float)) and self.fine_min_len_s > 0,
            "a length > 0 seconds",
        )
        _check(
            "fine_max_len_s",
            self.fine_max_len_s,
            isinstance(self.fine_max_len_s, (int, float))
            and self.fine_max_len_s >= self.fine_min_len_s,
            f"a length >= fine_min_len_s={self.fine_min_len_s} seconds",
        )
        _check(
            "coarse_kernel",
            self.coarse_kernel,
            self.coarse_kernel in ("labels", "dtak"),
            "'labels' or 'dtak'",
        )
        _check(
            "random_state",
            self.random_state,
            self.random_state is None or is_int(self.random_state),
            "None or an integer seed",
        )
