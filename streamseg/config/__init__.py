"""Frozen configuration dataclasses, validated once at construction.

One module per area (lof, aca, daemon, repetitions); CLI flags and TOML keys map 1:1 onto the
fields. Times are in seconds so one configuration serves 30, 100 and 120 Hz streams.
"""

from __future__ import annotations

from streamseg.config._base import _check, config_from_dict
from streamseg.config.aca import ACAConfig
from streamseg.config.daemon import DaemonConfig
from streamseg.config.lof import LOFConfig
from streamseg.config.repetitions import RepetitionConfig

__all__ = [
    "ACAConfig",
    "DaemonConfig",
    "LOFConfig",
    "RepetitionConfig",
    "_check",
    "config_from_dict",
]
