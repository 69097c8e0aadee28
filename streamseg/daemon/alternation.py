"""One action whose two halves HACA labels apart: a revision's alternations merged.

HACA's clusters are motions a few segments long, not actions: the two halves of one cyclic
action (left and right knee raises) often fall in two clusters, and a revision then changes
label at every half cycle (CMU 13_30, the knee raises: labels 7, 3, 7, 3 in segments of
1-2 s). A consumer takes every label change of a revision as a boundary between actions, so
the daemon's revisions merge such an alternation before they are published: runs A, B, A, B
with each B a single segment are one run of A (:func:`merge_alternations`). The
alternation's two ends stay boundaries. No parameter: "one segment" is HACA's own unit
(at most ``ACAConfig.max_len_s``). Why, and what it did to the consumer's view:
``docs/decisions.md`` (Revisions: alternations are one action).
"""

from __future__ import annotations


def merge_alternations(segments) -> list:
    """``segments`` with every alternation of two labels relabelled as one run of the first.

    An alternation: runs A, B, A, B (and on: A, B, A, B, A, ...), each B a single segment,
    B at least twice. One B between two runs of A is not enough: a short action of its own
    is one segment too, between two actions HACA may cluster together (HDM05 joins).

    Parameters
    ----------
    segments : sequence of (start, end, label)
        Consecutive segments tiling a range of stream frames, as a relabel returns them.

    Returns
    -------
    list of (start, end, label)
        The same segments (same frames, same order), each with the label of its run.
    """
    segments = [tuple(s) for s in segments]
    runs = []  # [label, indices of the segments in the run]
    for j, (_, _, lab) in enumerate(segments):
        if runs and runs[-1][0] == lab:
            runs[-1][1].append(j)
        else:
            runs.append([lab, [j]])
    i = 0
    while i < len(runs) - 2:
        a, b = runs[i][0], runs[i + 1][0]
        if len(runs[i + 1][1]) == 1 and runs[i + 2][0] == a:
            j, partners = i + 2, 1  # runs[i..j] alternate; partners: the single Bs in it
            while j + 1 < len(runs) and len(runs[j + 1][1]) == 1 and runs[j + 1][0] == b:
                partners += 1
                if j + 2 < len(runs) and runs[j + 2][0] == a:
                    j += 2
                else:
                    j += 1
                    break
            if partners >= 2:
                for run in runs[i + 1 : j + 1]:
                    runs[i][1] += run[1]
                del runs[i + 1 : j + 1]
                continue  # the merged run may start another alternation
        i += 1
    out = list(segments)
    for lab, idx in runs:
        for j in idx:
            a, b, _ = segments[j]
            out[j] = (a, b, lab)
    return out
