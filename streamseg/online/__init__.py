"""Online (streaming) detectors: ``learn_one`` / ``learn_many`` return events."""

# --- LOF (issue 3) ---------------------------------------------------------------------------
from streamseg.online.events import Cut
from streamseg.online.lof import StreamingLOFSegmenter
from streamseg.online.lof import warmup as warmup_lof

# --- repetitions (issue 6) -------------------------------------------------------------------
from streamseg.online.repetition import Rep, RepetitionCounter

__all__ = ["Cut", "StreamingLOFSegmenter", "warmup_lof", "Rep", "RepetitionCounter"]
