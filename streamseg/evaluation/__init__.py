"""Scoring segmenters against human labels.

- :mod:`~streamseg.evaluation.labels`: reading label files;
- :mod:`~streamseg.evaluation.metrics`: cut F1, covering, Hungarian frame accuracy, ...;
- :mod:`~streamseg.evaluation.datasets`: the bundled recordings and HDM05 joins;
- :mod:`~streamseg.evaluation.corpus`: every method on every labelled recording
  (``streamseg eval --all``).
"""

from streamseg.evaluation.corpus import (
    STREAMSEG_METHODS,
    LabelledRecording,
    Prediction,
    discover,
    evaluate_all,
    format_table,
    score,
)

__all__ = [
    "STREAMSEG_METHODS",
    "LabelledRecording",
    "Prediction",
    "discover",
    "evaluate_all",
    "format_table",
    "score",
]
