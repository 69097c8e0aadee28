"""The per-stream memory of actions that keeps ids beyond the relabel history."""

from __future__ import annotations

from dataclasses import dataclass

from streamseg.config._base import _check


@dataclass(frozen=True)
class LabelMemoryConfig:
    """Exemplar memory of a stream's actions (:mod:`streamseg.offline.label_memory`).

    Attributes
    ----------
    max_ids : int
        Ids remembered at most; beyond, absent ids are forgotten, shortest-lived first.
    per_id : int
        Exemplar segments kept per id.
    exemplar_s : float
        Seconds of features in one exemplar at most.
    rate_hz : float
        Exemplars keep every ``round(fps / rate_hz)``-th frame (at least every frame).
    recall_ratio : float
        A cluster takes a remembered id when its DTAK to it is >= this x their own DTAKs.
    recall_margin : float
        ... and exceeds its ratio to any other remembered id by this much.
    recall_confirm : int
        Revisions in a row that must propose the same pair (1 or 2).
    recall_pieces : int
        Pieces of a candidate cluster compared at most.
    recall_within : int
        Revisions (from the one that gave it) in which a new id can become an old one.
    merge_present : bool
        A cluster may join an id the revision holds (one action split in two) if DTAK-alike.
    merge_ratio, merge_margin : float
        The thresholds of ``merge_present``.
    merge_adjacent : bool
        ``merge_present`` only joins a cluster to an id one of whose runs it touches.

    Memory per stream is at most ``max_ids * per_id * ceil(exemplar_s * rate_hz)`` feature
    rows of float32: with the defaults and 17 features, 16 x 2 x 60 x 17 x 4 B = 130 kB
    (:meth:`max_bytes`), plus a few integers per id (run length, last frame, birth revision,
    a pending proposal) for at most ``max_ids`` ids and those of the last revision. The recall
    and merge tests in full: :mod:`streamseg.offline.recall`. Why each default:
    ``docs/decisions.md`` (Labels).
    """

    max_ids: int = 16
    per_id: int = 2
    exemplar_s: float = 2.0
    rate_hz: float = 30.0
    recall_ratio: float = 0.5
    recall_margin: float = 0.1
    recall_confirm: int = 1
    recall_pieces: int = 4
    recall_within: int = 2
    merge_present: bool = True
    merge_ratio: float = 0.5
    merge_margin: float = 0.1
    merge_adjacent: bool = True

    def __post_init__(self):
        def is_int(v):
            return isinstance(v, int) and not isinstance(v, bool)

        _check(
            "max_ids", self.max_ids, is_int(self.max_ids) and self.max_ids >= 1, "an integer >= 1"
        )
        _check("per_id", self.per_id, is_int(self.per_id) and self.per_id >= 1, "an integer >= 1")
        _check(
            "exemplar_s",
            self.exemplar_s,
            isinstance(self.exemplar_s, (int, float))
            and not isinstance(self.exemplar_s, bool)
            and self.exemplar_s > 0,
            "a length > 0 seconds",
        )
        _check(
            "rate_hz",
            self.rate_hz,
            isinstance(self.rate_hz, (int, float))
            and not isinstance(self.rate_hz, bool)
            and self.rate_hz > 0,
            "a rate > 0 Hz",
        )
        for name in ("merge_present", "merge_adjacent"):
            _check(
                name, getattr(self, name), isinstance(getattr(self, name), bool), "True or False"
            )
        for name in ("recall_ratio", "recall_margin", "merge_ratio", "merge_margin"):
            v = getattr(self, name)
            _check(
                name,
                v,
                isinstance(v, (int, float)) and not isinstance(v, bool) and 0 <= v < float("inf"),
                "a finite number >= 0",
            )
        _check(
            "recall_confirm",
            self.recall_confirm,
            self.recall_confirm in (1, 2) and is_int(self.recall_confirm),
            "1 or 2",
        )
        _check(
            "recall_pieces",
            self.recall_pieces,
            is_int(self.recall_pieces) and self.recall_pieces >= 2,
            "an integer >= 2",
        )
        _check(
            "recall_within",
            self.recall_within,
            is_int(self.recall_within) and self.recall_within >= 1,
            "an integer >= 1",
        )

    def max_bytes(self, n_features: int) -> int:
        """Upper bound of one stream's memory in bytes for ``n_features`` features."""
        import math

        rows = math.ceil(self.exemplar_s * self.rate_hz)
        return self.max_ids * self.per_id * rows * n_features * 4
