"""Human labels of a replayed recording, and how far the live output agrees with them so far."""

from __future__ import annotations

import numpy as np

from streamseg.evaluation.labels import cut_windows, frame_labels, read_labels, true_cuts
from streamseg.evaluation.metrics import cut_scores, matched_frame_accuracy


class HumanLabels:
    """The human segments of one sequence (0-based, end exclusive), as the page draws them.

    Attributes
    ----------
    rows : list of [start, end, name]
    """

    def __init__(self, segments):
        self.segments = list(segments)
        self.rows = [[s.start, s.end, s.label] for s in self.segments]
        self.names = sorted({s.label for s in self.segments})
        self.n = max((s.end for s in self.segments), default=0)

    @classmethod
    def read(cls, path, sequence: str) -> HumanLabels:
        return cls(read_labels(path, sequence))

    def windows(self, fps: float | None) -> list:
        """Acceptance window of each human boundary: the file's own, else +-1 s (the flat
        tolerance ``streamseg eval`` uses)."""
        own = cut_windows(self.segments)
        if any(lo != hi for lo, hi in own) or not fps:
            return own
        tol = int(round(1.0 * fps))
        return [(c - tol, c + tol) for c in true_cuts(self.segments)]

    def agreement(self, segments, cuts, fps: float | None = None) -> dict:
        """Agreement over the frames relabelled so far.

        Parameters
        ----------
        segments : list of [start, end, label]
            The newest relabelled label of each frame.
        cuts : list of dict
            Provisional cuts (``frame``).
        fps : float, optional
            Frame rate, for the +-1 s boundary tolerance of files without windows.

        Returns
        -------
        dict
            ``frame_accuracy`` (Hungarian-matched, over the relabelled frames the people
            labelled), ``frames`` (how many), ``match`` (id -> human action name, for the
            colour key), ``cut_recall`` (of the human boundaries whose acceptance window
            the relabelled frames have passed, the fraction with a provisional cut inside it),
            ``boundaries`` (how many have passed).
        """
        end = min(max((b for _, b, _ in segments), default=0), self.n)
        relab = np.full(end, -1, dtype=np.int64)
        for a, b, lab in segments:
            relab[a : min(b, end)] = lab
        truth = frame_labels(self.segments, end)
        ok = (relab >= 0) & (truth >= 0)
        acc, match = matched_frame_accuracy(relab[ok], truth[ok]) if ok.any() else (None, {})
        all_windows = self.windows(fps)
        passed = [i for i, (_, hi) in enumerate(all_windows) if hi < end]
        windows = [all_windows[i] for i in passed]
        truth_cuts = [true_cuts(self.segments)[i] for i in passed]
        pred = [c["frame"] for c in cuts if c["frame"] < end]
        recall = cut_scores(pred, truth_cuts, windows=windows)["recall"] if passed else None
        return {
            "frame_accuracy": None if acc is None else round(acc, 4),
            "frames": int(ok.sum()),
            "match": {str(k): self.names[v] for k, v in match.items()},
            "cut_recall": None if recall is None else round(recall, 4),
            "boundaries": len(passed),
        }
