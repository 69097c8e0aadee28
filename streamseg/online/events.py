"""Events the streaming detectors emit (library objects; the wire messages they become are
:mod:`streamseg.protocol.messages`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class CutEvent:
    """A detected cut: a new segment starts at ``frame``.

    Attributes
    ----------
    frame : int
        0-based stream frame the cut refers to (LOF: the peak window's centre moved to the
        largest before/after histogram contrast nearby, see ``LOFConfig.refine_s``).
    score : float
        LOF of the peak window when the cut was decided.
    emitted_at : int
        0-based index of the frame whose arrival made the detector emit the cut; the latency
        in frames is ``emitted_at - frame``.
    provisional : bool
        True for cuts a later relabelling stage (ACA) may still move or drop.
    """

    frame: int
    score: float
    emitted_at: int
    provisional: bool = True

    @property
    def latency(self) -> int:
        """Frames between the cut and its emission."""
        return self.emitted_at - self.frame
