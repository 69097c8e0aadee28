"""Live repetitions grouped into sets: each ``rep`` event gets its action label and a count
that restarts at a new set.

The action label of a repetition is the label the newest relabel (``segments`` event) gives
the repetition's middle frame. A relabel covers the stream only up to when it ran (every
``relabel_interval`` seconds), so a repetition after its end takes the label of the last
relabelled segment as long as no live cut came since that segment began (the action has gone
on), and no label (None) otherwise: the next relabel will say.

A new set starts when the repetition counter restarts (a whole buffer without repetitive
motion) or when the label changes from one repetition to the next (another exercise). An
unknown label does not start a set.
"""

from __future__ import annotations

__all__ = ["SetTracker"]


class SetTracker:
    """Per-stream set state for the live ``rep`` events.

    Attributes
    ----------
    count_ : int
        Repetitions of the current set so far.
    set_index_ : int
        Sets started in the stream so far minus one (the current set's index; -1 before).
    """

    def __init__(self):
        self.count_ = 0
        self.set_index_ = -1
        self._label = None

    @staticmethod
    def label_at(start: int, end: int, segments, window_end, cut_frames=()):
        """The action label of frames ``[start, end)`` (see the module docstring).

        Parameters
        ----------
        segments : sequence of (start, end, label)
            The newest relabel, in stream frames (empty: none yet).
        window_end : int or None
            End of the frames that relabel covered.
        cut_frames : iterable of int
            Live cuts (stream frames).
        """
        if not segments:
            return None
        mid = (int(start) + int(end)) // 2
        if mid < window_end:
            for s, e, lab in segments:
                if s <= mid < e:
                    return int(lab)
            return None
        s, _, lab = segments[-1]
        if any(s < c <= start for c in cut_frames):
            return None
        return int(lab)

    def assign(self, counter_count: int, label):
        """(count in the set, set index) of the next repetition.

        Parameters
        ----------
        counter_count : int
            The counter's own running count (1: it restarted).
        label : int or None
        """
        new = (self.set_index_ < 0 or counter_count == 1
               or (label is not None and self._label is not None and label != self._label))
        if new:
            self.set_index_ += 1
            self.count_ = 0
        if label is not None:
            self._label = label
        self.count_ += 1
        return self.count_, self.set_index_
