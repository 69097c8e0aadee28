"""Offline segmentation methods (whole sequences or buffered windows): ``fit`` / ``predict``.

The names below are loaded on first use, so importing one module of this package
(``streamseg.offline.lof``) does not import every method's dependencies.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from streamseg._lazy import lazy_exports

if TYPE_CHECKING:  # what documentation tools and type checkers read
    from streamseg.offline.aca import ACAEngine
    from streamseg.offline.aca_models import ACA, HACA
    from streamseg.offline.aca_segmenter import ACASegmenter
    from streamseg.offline.haca import HACAEngine
    from streamseg.offline.lof import LOFSegmenter
    from streamseg.offline.model_selection import fit_aca
    from streamseg.offline.relabel import WindowSegmentation, relabel_window, warmup
    from streamseg.offline.relabel import warmup as warmup_aca
    from streamseg.offline.repetition import RepetitionSegmenter

_EXPORTS = {
    "ACA": "streamseg.offline.aca_models",
    "ACAEngine": "streamseg.offline.aca",
    "ACASegmenter": "streamseg.offline.aca_segmenter",
    "HACA": "streamseg.offline.aca_models",
    "HACAEngine": "streamseg.offline.haca",
    "LOFSegmenter": "streamseg.offline.lof",
    "RepetitionSegmenter": "streamseg.offline.repetition",
    "WindowSegmentation": "streamseg.offline.relabel",
    "fit_aca": "streamseg.offline.model_selection",
    "relabel_window": "streamseg.offline.relabel",
    # the relabeller's kernels (the daemon warms them at start)
    "warmup": ("streamseg.offline.relabel", "warmup"),
    "warmup_aca": ("streamseg.offline.relabel", "warmup"),
}
__all__ = [
    "ACA",
    "ACAEngine",
    "ACASegmenter",
    "HACA",
    "HACAEngine",
    "LOFSegmenter",
    "RepetitionSegmenter",
    "WindowSegmentation",
    "fit_aca",
    "relabel_window",
    "warmup",
    "warmup_aca",
]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
