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
    pending : bool
        True for an early decision (``LOFConfig.early_delay_s``): a later
        :class:`ConfirmEvent` or :class:`WithdrawEvent` of the same frame settles it.
    """

    frame: int
    score: float
    emitted_at: int
    provisional: bool = True
    pending: bool = False

    @property
    def latency(self) -> int:
        """Frames between the cut and its emission."""
        return self.emitted_at - self.frame


@dataclass(frozen=True)
class ConfirmEvent:
    """The pending cut at ``frame`` stands: the confirming stage decided the same cut.

    Attributes
    ----------
    frame : int
        The pending cut's frame.
    score : float
        LOF of the peak window when the confirming stage decided it.
    emitted_at : int
        Frame whose arrival made the detector confirm it.
    """

    frame: int
    score: float
    emitted_at: int

    @property
    def latency(self) -> int:
        return self.emitted_at - self.frame


@dataclass(frozen=True)
class WithdrawEvent:
    """The pending cut at ``frame`` is taken back.

    Attributes
    ----------
    frame : int
        The pending cut's frame.
    emitted_at : int
        Frame whose arrival made the detector withdraw it.
    moved : bool
        True when the confirming stage found the cut at another frame nearby: a cut at that
        frame follows (final at once); False when it found no cut there.
    """

    frame: int
    emitted_at: int
    moved: bool = False

    @property
    def latency(self) -> int:
        return self.emitted_at - self.frame


def final_cuts(events) -> list[CutEvent]:
    """The final decisions among ``events`` (in order): every cut that is not pending, and
    each confirmed pending cut at its confirmation (score and ``emitted_at`` of the
    :class:`ConfirmEvent`). With two stages these are the single-stage detector's cuts at the
    confirmation delay, event for event; with one stage, ``events`` unchanged."""
    return [
        CutEvent(ev.frame, ev.score, ev.emitted_at) if isinstance(ev, ConfirmEvent) else ev
        for ev in events
        if isinstance(ev, ConfirmEvent) or (isinstance(ev, CutEvent) and not ev.pending)
    ]


def first_emissions(events) -> list[int]:
    """For each of :func:`final_cuts` (same order), the frame whose arrival first told a
    listener of it: the pending cut the final decision confirmed, or the pending cut withdrawn
    as ``moved`` right before this cut was emitted nearby; else the final decision itself.
    With one stage, every cut's ``emitted_at``."""
    out, pending_at, carry = [], {}, None
    for ev in events:
        if isinstance(ev, CutEvent) and ev.pending:
            pending_at[ev.frame] = ev.emitted_at
        elif isinstance(ev, ConfirmEvent):
            out.append(pending_at.pop(ev.frame, ev.emitted_at))
        elif isinstance(ev, WithdrawEvent):
            carry = pending_at.pop(ev.frame, None) if ev.moved else None
        else:  # a final cut: after a moved withdraw, that pending cut announced it
            out.append(ev.emitted_at if carry is None else carry)
            carry = None
    return out
