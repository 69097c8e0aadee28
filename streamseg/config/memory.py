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
        Stream ids remembered at most; beyond it, ids the current revision does not hold
        are forgotten, the shortest-lived first (:mod:`streamseg.offline.label_memory`).
    per_id : int
        Exemplar segments kept per id.
    exemplar_s : float
        Seconds of features in one exemplar at most.
    rate_hz : float
        Exemplars keep every ``round(fps / rate_hz)``-th frame (at least every frame).
    recall_ratio : float
        A candidate cluster takes a remembered id only when its DTAK to the id's exemplars is
        at least ``recall_ratio`` times the larger of its own pieces' DTAK to each other and
        the exemplars' to each other (:mod:`streamseg.offline.recall`).
    recall_margin : float
        ... and exceeds its ratio to any other remembered id by this much.
    recall_confirm : int
        Revisions in a row that must propose the same pair (1 or 2).
    recall_pieces : int
        Pieces of a candidate cluster compared at most.
    recall_within : int
        A new id can still be recalled (replaced by an old one) in the revision that gave it
        and the next ``recall_within - 1`` ones.
    merge_present : bool
        A candidate cluster may also take an id the revision already holds, when it passes
        the recall's relative test against that id's exemplars with ``merge_ratio`` and
        ``merge_margin`` (two clusters of one revision then share an id: one action the fit
        split in two; :func:`streamseg.offline.recall.merge_into_present`). Works from the
        first revisions on (no origin rule: it recalls nothing).
    merge_ratio, merge_margin : float
        The thresholds of ``merge_present``.
    merge_adjacent : bool
        ``merge_present`` only joins a cluster to an id one of whose runs it touches in the
        revision (the two clusters of a split action tile it;
        :func:`streamseg.offline.recall.touches`).

    ``merge_present`` and ``merge_adjacent`` are on (issue 12, 2026-12-02,
    ``benchmarks/id_fragments.py``; train pair ret_14_86_14 and 02_walk_punch_sword_wash, the
    17 other streams held out; rule declared before the held-out run: mean accuracy not
    lower, no stream lower by more than 0.01, ids per action lower). Ratio 0.5 and margin
    0.1 are the recall's, the middle of the plateau ratio 0.3-0.7 x margin 0.1-0.2 on the
    train pair. Without the guard the merge cost 14_20 0.028 (its arm circles joined the
    twist's id, the two 23 s apart in one revision) and stayed off. With it, held out, in
    simulated revisions: mean accuracy 0.749 -> 0.765, ids per action 1.263 -> 1.200
    (published 1.913 -> 1.769), purity 0.806 -> 0.820; the real daemon at real time
    (``--daemon 1``): 0.744 -> 0.764, ids per action 1.253 -> 1.195 (published 1.940 ->
    1.761), purity 0.812 -> 0.827; no stream lower in either mode (14_20 +0.057 / +0.067,
    hdm_bd_1 +0.120 / +0.120, 02_wash_sword_walk_punch +0.075 / +0.075).

    Memory per stream is at most ``max_ids * per_id * ceil(exemplar_s * rate_hz)`` feature
    rows of float32: with the defaults and 17 features, 16 x 2 x 60 x 17 x 4 B = 130 kB
    (:meth:`max_bytes`), plus a few integers per id (run length, last frame, birth revision,
    a pending proposal) for at most ``max_ids`` ids and those of the last revision.
    ``max_ids``, ``per_id``, ``exemplar_s`` and ``rate_hz`` were chosen on two streams of
    ``benchmarks/label_memory.py`` in issue 12's second round; the ``recall_*`` settings on
    the same two (``--grid``, :mod:`streamseg.offline.recall`): ratios 0.3-0.7, margins
    0-0.2 and ``recall_within`` 2-3 gave the same best result there, the defaults sit in the
    middle; a ratio of 1 (as similar as the cluster to itself) recalled nothing.
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

        _check("max_ids", self.max_ids, is_int(self.max_ids) and self.max_ids >= 1,
               "an integer >= 1")
        _check("per_id", self.per_id, is_int(self.per_id) and self.per_id >= 1,
               "an integer >= 1")
        _check("exemplar_s", self.exemplar_s, isinstance(self.exemplar_s, (int, float))
               and not isinstance(self.exemplar_s, bool) and self.exemplar_s > 0,
               "a length > 0 seconds")
        _check("rate_hz", self.rate_hz, isinstance(self.rate_hz, (int, float))
               and not isinstance(self.rate_hz, bool) and self.rate_hz > 0, "a rate > 0 Hz")
        for name in ("merge_present", "merge_adjacent"):
            _check(name, getattr(self, name), isinstance(getattr(self, name), bool),
                   "True or False")
        for name in ("recall_ratio", "recall_margin", "merge_ratio", "merge_margin"):
            v = getattr(self, name)
            _check(name, v, isinstance(v, (int, float)) and not isinstance(v, bool)
                   and 0 <= v < float("inf"), "a finite number >= 0")
        _check("recall_confirm", self.recall_confirm, self.recall_confirm in (1, 2)
               and is_int(self.recall_confirm), "1 or 2")
        _check("recall_pieces", self.recall_pieces, is_int(self.recall_pieces)
               and self.recall_pieces >= 2, "an integer >= 2")
        _check("recall_within", self.recall_within, is_int(self.recall_within)
               and self.recall_within >= 1, "an integer >= 1")

    def max_bytes(self, n_features: int) -> int:
        """Upper bound of one stream's memory in bytes for ``n_features`` features."""
        import math

        rows = math.ceil(self.exemplar_s * self.rate_hz)
        return self.max_ids * self.per_id * rows * n_features * 4
