"""States of earlier releases: the one place that knows how they differ from today's.

:func:`migrate` brings the stored fields of a :class:`~streamseg.state.Stateful` component
from the version they were written in to its ``STATE_VERSION``, one version at a time: a
field added since gets the value a component of that release had in effect.

Daemon checkpoints of formats 5 (commit 3e14a8b, ``tests/fixtures/checkpoints_3e14a8b``) and 6
carry no per-component version; :func:`implied_version` says which version each component
of such a row was written in. Format 7 rows carry each component's own version.
"""

from __future__ import annotations

import numpy as np

from streamseg.state import StateVersionError

FORMAT = 7  # checkpoint rows written by this release: a version per component
READS = (5, 6, 7)  # checkpoint row formats restored by this release


def _lof_1(fields: dict) -> dict:
    from streamseg._kernels import lof_decide as ks

    # one-stage decision (no pending cuts); the decision's checks read every column
    fields.setdefault("_pend", np.zeros((0, 2), dtype=np.int64))
    geo = fields.get("_geo")
    if geo is not None and geo.size < ks.GEO_SIZE and "_cols" in fields:
        fields["_geo"] = np.append(geo, fields["_cols"])
    return fields


def _pipeline_1(fields: dict) -> dict:
    fields.setdefault("root", None)  # a detector without root speeds
    fields.setdefault("settlement", None)  # provisional cuts not settled by relabels
    return fields


def _pipeline_2(fields: dict) -> dict:
    # lost markers of a marker map were not placed live: none placed yet (nothing seen)
    fields.setdefault("marker_fill", None)
    return fields


def _counter_1(fields: dict) -> dict:
    fields.setdefault("near_misses_", {})
    fields.setdefault("_unliked", None)  # no ended set waiting to resume
    return fields


def _counter_2(fields: dict) -> dict:
    fields.setdefault("_final", False)  # stored only once finish() had run
    return fields


def _counter_3(fields: dict) -> dict:
    # before lost joints were bridged in the counter (its frames had every joint): a bridge
    # is made with the next frames, none of the frames seen waited
    if fields.get("_idx") is not None:
        from streamseg._kernels import rep_track as K
        from streamseg.online.rep_bridge import PoseBridge, bridge_frames

        bridge = PoseBridge(len(K.POINTS), bridge_frames(fields["fps"]), range(4))
        bridge.n_in = bridge.n_out = fields["n_seen_"] + sum(
            p.shape[0] for p in fields.get("_pending", [])
        )
        fields.setdefault("_bridge", bridge)
    fields.setdefault("_bridge", None)
    fields.setdefault("_waits", {})
    return fields


def _counter_4(fields: dict) -> dict:
    fields.setdefault("_skip", None)  # no fidget since the set's last repetition
    ring = fields["_ring"]
    # a set under way ([set, spans, amplitudes]) gets its repetitions' moving lengths
    for cur in (fields.get("_cur"), (fields.get("_unliked") or (None,))[0]):
        if cur is not None and len(cur) == 3:
            cur.append([ring.length((a, b, 0.0)) for a, b in cur[1]])
    return fields


def _counter_5(fields: dict) -> dict:
    # a set under way had no lead-in measured: its piece at the stream's end stands alone
    fields.setdefault("_lead", 0.0)
    return fields


def _speeds_1(fields: dict) -> dict:
    fields.setdefault("_order", None)  # columns in the order they are computed
    return fields


LOF = "streamseg.online.lof:StreamingLOFSegmenter"
PIPELINE = "streamseg.daemon.pipeline:StreamPipeline"
COUNTER = "streamseg.online.repetition:RepetitionCounter"
SPEEDS = "streamseg.online.speed_features:SpeedColumns"

# ("module:Class", version) -> the fields of version + 1
MIGRATIONS = {
    (LOF, 1): _lof_1,
    (PIPELINE, 1): _pipeline_1,
    (PIPELINE, 2): _pipeline_2,
    (COUNTER, 1): _counter_1,
    (COUNTER, 2): _counter_2,
    (COUNTER, 3): _counter_3,
    (COUNTER, 4): _counter_4,
    (COUNTER, 5): _counter_5,
    (SPEEDS, 1): _speeds_1,
}

# row format -> {"module:Class": version} where not 1 (formats before per-component versions)
_IMPLIED = {5: {}, 6: {LOF: 2, PIPELINE: 2, COUNTER: 2}}


def name_of(cls) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


def implied_version(fmt: int, name: str) -> int:
    """The version a component ``name`` of a checkpoint row of format ``fmt`` (5 or 6) has."""
    return _IMPLIED[fmt].get(name, 1)


def migrate(cls, version, fields: dict) -> dict:
    """Today's fields of a ``cls`` state stored at ``version``; raises StateVersionError."""
    name, now = name_of(cls), cls.STATE_VERSION
    if type(version) is not int or version > now or version < 1:
        raise StateVersionError(
            f"{cls.__qualname__} state version {version!r}: this release reads versions 1 to {now}"
        )
    while version < now:
        step = MIGRATIONS.get((name, version))
        if step is None:
            raise StateVersionError(
                f"{cls.__qualname__} state version {version}: no migration to version {version + 1}"
            )
        fields = step(fields)
        version += 1
    return fields


def upgrade(cls, state: dict):
    """``cls.from_state`` of a state of any version this release reads."""
    fields = migrate(cls, state["version"], dict(state["fields"]))
    return cls.from_state({"version": cls.STATE_VERSION, "fields": fields})
