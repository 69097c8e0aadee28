"""Offline segmentation methods (whole sequences or buffered windows): ``fit`` / ``predict``."""

from __future__ import annotations

from streamseg.offline.aca import ACA
from streamseg.offline.aca_segmenter import ACASegmenter
from streamseg.offline.haca import HACA
from streamseg.offline.lof import LOFSegmenter
from streamseg.offline.model_selection import fit_aca
from streamseg.offline.relabel import WindowSegmentation, relabel_window
from streamseg.offline.relabel import warmup as warmup_aca
from streamseg.offline.repetition import RepetitionSegmenter

warmup = warmup_aca  # the relabeller's kernels (the daemon warms them at start)

__all__ = ["ACA", "ACASegmenter", "HACA", "LOFSegmenter", "RepetitionSegmenter",
           "WindowSegmentation",
           "fit_aca", "relabel_window", "warmup", "warmup_aca"]
