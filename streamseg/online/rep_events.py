"""What the repetition counter reports: a repetition found live (:class:`RepEvent`), a set
(:class:`RepSet`), and the events of a stream fed in packets
(:mod:`streamseg.online.repetition` counts)."""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["RepEvent", "RepSet", "sets_of", "stream_events"]


@dataclass(frozen=True)
class RepEvent:
    """One repetition found live.

    Attributes
    ----------
    start, end : int
        Counter frame indices (0-based, end exclusive).
    count : int
        The repetition's number in its set (1 = the first).
    emitted_at : int
        Frames the counter had seen when it decided (``emitted_at - end`` is the delay),
        whatever the chunks the frames came in.
    set_index : int
        0-based index of its set in the stream.
    duration_s : float
        ``(end - start) / fps``.
    rom_deg : float or None
        Range of motion of the set's most moving joint (``rom_joint``) in this repetition,
        degrees (None without a skeleton: feature rows have no joints).
    rom_joint : str or None
        That joint (``l_knee``, ``r_shoulder`` ...:
        :data:`~streamseg.online.rep_pose.ROM_JOINTS`), chosen once a set starts, on its
        first repetitions.
    likeness : float or None
        ``1 - dissimilarity / max_dissimilarity`` to the repetition before it (the first:
        to the second); 1 for identical ones, 0 at the limit of the repetitive test.
    """

    start: int
    end: int
    count: int
    emitted_at: int
    set_index: int = 0
    duration_s: float = 0.0
    rom_deg: float | None = None
    rom_joint: str | None = None
    likeness: float | None = None


@dataclass
class RepSet:
    """A set: consecutive repetitions of one movement.

    Attributes
    ----------
    repetitions : list of (int, int)
        Frames, 0-based, end exclusive.
    dissimilarity : list of float
        DTW distance / amplitude of each repetition to the one before (first: None).
    end_reason : str
        Why the set ended: "unlike" (the next loop differs), "pause", "timeout", "end".
    rom_deg : list of float
        Each repetition's range of motion of ``rom_joint``, degrees (empty without joints).
    rom_joint : str or None
        The joint that moves most over the set's first repetitions.
    likeness : list of float
        Each repetition's :attr:`RepEvent.likeness`.
    """

    repetitions: list = field(default_factory=list)
    dissimilarity: list = field(default_factory=list)
    end_reason: str = ""
    rom_deg: list = field(default_factory=list)
    rom_joint: str | None = None
    likeness: list = field(default_factory=list)

    @property
    def start(self) -> int:
        return self.repetitions[0][0]

    @property
    def end(self) -> int:
        return self.repetitions[-1][1]

    @property
    def count(self) -> int:
        return len(self.repetitions)


def stream_events(counter, X, chunk: int) -> list[RepEvent]:
    """Every event of ``counter`` fed ``X`` ``chunk`` frames a call, then finished (what a
    stream in packets of ``chunk`` frames gets; the sets do not depend on ``chunk``)."""
    events = []
    for i in range(0, len(X), chunk):
        events += counter.learn_many(X[i : i + chunk])
    return events + counter.finish()


def sets_of(events) -> list:
    """The repetitions ``(start, end)`` of each set, by ``set_index``, from events."""
    out: dict = {}
    for e in events:
        out.setdefault(e.set_index, []).append((e.start, e.end))
    return [out[i] for i in sorted(out)]
