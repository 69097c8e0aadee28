"""Daemon options from TOML, and the skeleton of an announced stream."""

from __future__ import annotations

import numpy as np

from streamseg.config import DaemonConfig, config_from_dict
from streamseg.exceptions import ParameterError
from streamseg.recording import Skeleton


def load_config(path) -> tuple:
    """``(DaemonConfig, LOFConfig, ACAConfig, RepetitionConfig)`` (None: defaults) from TOML.

    Tables ``[daemon]``, ``[lof]``, ``[aca]``, ``[repetitions]``; keys are the dataclass
    fields.
    """
    from streamseg.config._toml import read_toml

    doc = read_toml(path, str(path), "no such config file")
    unknown = sorted(set(doc) - {"daemon", "lof", "aca", "repetitions"})
    if unknown:
        raise ParameterError(
            f"{path}: unknown table(s) {', '.join(unknown)}; "
            "expected [daemon], [lof], [aca], [repetitions]"
        )
    daemon = config_from_dict(DaemonConfig, doc.get("daemon", {}))
    if daemon.markers:  # a marker map beside the config file, wherever serve runs
        import dataclasses
        from pathlib import Path

        daemon = dataclasses.replace(
            daemon, markers=str(Path(path).expanduser().parent / Path(daemon.markers).expanduser())
        )
    lof = aca = None
    if "lof" in doc:
        from streamseg.config import LOFConfig

        lof = config_from_dict(LOFConfig, doc["lof"])
    if "aca" in doc:
        from streamseg.config import ACAConfig

        aca = config_from_dict(ACAConfig, doc["aca"])
    rep = None
    if "repetitions" in doc:
        from streamseg.config import RepetitionConfig

        rep = config_from_dict(RepetitionConfig, doc["repetitions"])
    return daemon, lof, aca, rep


def skeleton_from(names, parents, units="unknown", up="y") -> Skeleton:
    """A Skeleton from announced joint names and parents (offsets unknown on the wire)."""
    n = len(names)
    return Skeleton(tuple(names), np.asarray(parents, dtype=np.int64), np.zeros((n, 3)), units, up)
