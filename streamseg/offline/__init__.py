"""Offline segmentation methods (whole sequences or buffered windows)."""

# --- LOF (issue 3) ---------------------------------------------------------------------------
from streamseg.offline.lof import LOFSegmenter

# isort: split

# --- ACA (issue 4) ---------------------------------------------------------------------------
from streamseg.offline.aca import ACA
from streamseg.offline.haca import HACA
from streamseg.offline.relabel import WindowSegmentation, relabel_window, warmup

# --- repetitions (issue 6) -------------------------------------------------------------------
from streamseg.offline.repetition import RepetitionSegmenter

__all__ = ["LOFSegmenter", "ACA", "HACA", "WindowSegmentation", "relabel_window", "warmup",
           "RepetitionSegmenter"]
