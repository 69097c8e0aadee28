"""Online (streaming) detectors: ``learn_one`` / ``learn_many`` return the events they decide."""

from __future__ import annotations

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

__all__ = ["ConfirmEvent", "CutEvent", "RepEvent", "RepetitionCounter", "StreamingLOFSegmenter",
           "WithdrawEvent", "final_cuts", "first_emissions", "warmup_lof"]
