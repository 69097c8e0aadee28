"""Exceptions raised by streamseg; every one carries a message that says how to fix it."""

from __future__ import annotations


class StreamsegError(Exception):
    """Base class of every error streamseg raises on purpose."""


class ParameterError(StreamsegError, ValueError):
    """A parameter has a value outside its allowed range or type."""


class NotFittedError(ParameterError, AttributeError):
    """A fitted attribute or ``predict()`` was asked of an estimator before ``fit``.

    An AttributeError too, so ``hasattr(estimator, "labels_")`` stays False before ``fit``.
    """


class RecordingError(StreamsegError):
    """A recording file cannot be read.

    Parameters
    ----------
    path : str
        The file being read.
    line : int or None
        1-based line number in the file (or frame number where ``what`` says so).
    found : str
        What the reader found.
    expected : str
        What the reader expected there.
    partial : Recording or None
        The good frames read before the error, when any were read.
    """

    def __init__(self, path, line, found, expected, partial=None):
        self.path = str(path)
        self.line = line
        self.found = found
        self.expected = expected
        self.partial = partial
        where = f"{self.path}:{line}" if line is not None else self.path
        super().__init__(f"{where}: found {found}; expected {expected}")


class TruncatedRecordingError(RecordingError):
    """The last frame of a recording is incomplete; ``partial`` holds the good frames."""


class SkeletonError(StreamsegError):
    """A skeleton lacks joints a feature needs, or a skeleton file is missing."""


class ProtocolError(StreamsegError):
    """A wire message cannot be decoded or fails validation."""
