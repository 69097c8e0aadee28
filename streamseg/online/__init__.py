"""Online (streaming) detectors: ``learn_one`` / ``learn_many`` return the events they decide.

The names below are loaded on first use: importing the cut detector does not import the
repetition counter's dependencies.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from streamseg._lazy import lazy_exports

if TYPE_CHECKING:  # what documentation tools and type checkers read
    from streamseg.online.events import (
        ConfirmEvent,
        CutEvent,
        WithdrawEvent,
        final_cuts,
        first_emissions,
    )
    from streamseg.online.lof import StreamingLOFSegmenter
    from streamseg.online.lof import warmup as warmup_lof
    from streamseg.online.repetition import RepetitionCounter, RepEvent

_EXPORTS = {
    "ConfirmEvent": "streamseg.online.events",
    "CutEvent": "streamseg.online.events",
    "WithdrawEvent": "streamseg.online.events",
    "final_cuts": "streamseg.online.events",
    "first_emissions": "streamseg.online.events",
    "StreamingLOFSegmenter": "streamseg.online.lof",
    "RepetitionCounter": "streamseg.online.repetition",
    "RepEvent": "streamseg.online.repetition",
    "warmup_lof": ("streamseg.online.lof", "warmup"),
}
__all__ = [
    "ConfirmEvent",
    "CutEvent",
    "RepEvent",
    "RepetitionCounter",
    "StreamingLOFSegmenter",
    "WithdrawEvent",
    "final_cuts",
    "first_emissions",
    "warmup_lof",
]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
