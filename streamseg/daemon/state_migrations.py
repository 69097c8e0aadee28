"""Checkpoints of earlier releases: the one place that knows how their state differs.

A checkpoint row carries its format (:data:`FORMAT`). :func:`migrate` turns the fields of an
object stored in an older format into today's, class by class, before
:func:`streamseg.daemon.state_codec.load` sets them: a field added since gets the value a
stream of that release had in effect. Formats outside :data:`READS` are refused at restore
with one line naming the file, the stream and the format. A class that gains state adds its
default here (and bumps :data:`FORMAT` when the meaning of stored fields changes), instead of
``hasattr`` checks in the algorithm.
"""

from __future__ import annotations

import numpy as np

FORMAT = 7  # written by this release
READS = (5, 6, 7)  # restored by this release (5: 3e14a8b, tests/fixtures/checkpoints_3e14a8b)


def _lof(fields: dict) -> dict:
    from streamseg._kernels import lof_stream as ks

    # one-stage decision (no pending cuts); the decision's checks read every column
    fields.setdefault("_pend", np.zeros((0, 2), dtype=np.int64))
    geo = fields.get("_geo")
    if geo is not None and geo.size < ks.GEO_SIZE and "_cols" in fields:
        fields["_geo"] = np.append(geo, fields["_cols"])
    return fields


def _pipeline(fields: dict) -> dict:
    fields.setdefault("root", None)  # a detector without root speeds
    fields.setdefault("settlement", None)  # provisional cuts not settled by relabels
    return fields


def _counter(fields: dict) -> dict:
    fields.setdefault("near_misses_", {})
    fields.setdefault("_unliked", None)  # no ended set waiting to resume
    return _counter_6(fields)


def _counter_6(fields: dict) -> dict:
    # before lost joints were bridged in the counter (its frames had every joint): a bridge
    # is made with the next frames, none of the frames seen waited
    if fields.get("_idx") is not None:
        from streamseg._kernels import rep_track as K
        from streamseg.online.rep_bridge import PoseBridge, bridge_frames

        bridge = PoseBridge(len(K.POINTS), bridge_frames(fields["fps"]), range(4))
        bridge.n_in = bridge.n_out = fields["n_seen_"] + sum(
            p.shape[0] for p in fields.get("_pending", []))
        fields.setdefault("_bridge", bridge)
    fields.setdefault("_bridge", None)
    fields.setdefault("_waits", {})
    return fields


# (format, "module:Class") -> the migration of its fields to FORMAT
MIGRATIONS = {
    (5, "streamseg.online.lof:StreamingLOFSegmenter"): _lof,
    (5, "streamseg.daemon.pipeline:StreamPipeline"): _pipeline,
    (5, "streamseg.online.repetition:RepetitionCounter"): _counter,
    (6, "streamseg.online.repetition:RepetitionCounter"): _counter_6,
}


def migrate(name: str, fields: dict, fmt: int) -> dict:
    """Today's fields of an object of class ``name`` (``module:Class``) stored in ``fmt``."""
    if fmt == FORMAT:
        return fields
    step = MIGRATIONS.get((fmt, name))
    return step(fields) if step is not None else fields
