"""The action label of a live repetition (the sets themselves are the counter's).

The action label of a repetition is the label the newest relabel (``segments`` event) gives
the repetition's middle frame. A relabel covers the stream only up to when it ran (every
``relabel_interval`` seconds), so a repetition after its end takes the label of the last
relabelled segment as long as no live cut came since that segment began (the action has gone
on), and no label (None) otherwise: the next relabel will say.

Sets are not cut here: the counter ends a set where the movement changes, the person pauses
or stops repeating (:mod:`streamseg.online.repetition`), live and offline alike; the label
only names the exercise.
"""

from __future__ import annotations

__all__ = ["label_at"]


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

    Returns
    -------
    int or None
    """
    if not segments:
        return None
    mid = (int(start) + int(end)) // 2
    if window_end is not None and mid < window_end:
        for s, e, lab in segments:
            if s <= mid < e:
                return int(lab)
        return None
    s, _, lab = segments[-1]
    if any(s < c <= start for c in cut_frames):
        return None
    return int(lab)
