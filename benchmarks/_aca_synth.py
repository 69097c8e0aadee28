"""Synthetic 1-D sequences of section 5.1 (Zhou et al. 2008), shared by the ACA benchmarks:
the generator lives in :mod:`streamseg.evaluation.synthetic` so the tests use it too."""

from streamseg.evaluation.synthetic import synthetic_sequence

__all__ = ["synthetic_sequence"]
