"""The result type every segmenter returns, and the checks every estimator shares.

The estimators (:class:`~streamseg.offline.LOFSegmenter`,
:class:`~streamseg.offline.ACASegmenter`, :class:`~streamseg.offline.ACA`,
:class:`~streamseg.offline.HACA`, :class:`~streamseg.offline.RepetitionSegmenter`)
follow one convention, spelled out in :class:`Estimator`: ``(config=None, fps=120.0)`` at
construction, ``fit(X)`` returns the estimator, ``predict()`` (or ``fit_predict(X)``)
returns a list of :class:`Segment` tiling the frames it was fitted on, and fitted attributes
end in ``_`` and are returned as copies. Asking before ``fit`` raises
:class:`~streamseg.exceptions.NotFittedError`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from streamseg.exceptions import NotFittedError


class Segment(NamedTuple):
    """Frames ``[start, end)`` (0-based, end exclusive) and their label.

    ``label`` is an action id (int) for clusterings, the segment's index for cut detectors
    (which do not say which segments are alike), a repetition's index for repetitions.
    """

    start: int
    end: int
    label: int


def segments_from_cuts(cuts, n_frames: int) -> list[Segment]:
    """The segments between ``cuts`` (sorted frames) over ``n_frames``, labelled 0, 1, ..."""
    bounds = [0, *(int(c) for c in cuts if 0 < int(c) < n_frames), int(n_frames)]
    bounds = sorted(set(bounds))
    return [Segment(s, e, i) for i, (s, e) in enumerate(zip(bounds[:-1], bounds[1:]))]


def segments_from_labels(labels) -> list[Segment]:
    """Runs of equal per-frame labels, shape (n_frames,) -> list of Segment."""
    labels = np.asarray(labels)
    if labels.size == 0:
        return []
    cuts = np.flatnonzero(labels[1:] != labels[:-1]) + 1
    bounds = np.concatenate([[0], cuts, [labels.size]])
    return [Segment(int(s), int(e), int(labels[s])) for s, e in zip(bounds[:-1], bounds[1:])]


def _copy(value):
    if isinstance(value, np.ndarray):
        return value.copy()
    if isinstance(value, list):
        return list(value)
    if isinstance(value, dict):
        return dict(value)
    return value


class Estimator:
    """Base of the offline estimators: fitted attributes (public names ending in ``_``) are
    kept apart and handed out as copies, so mutating a result never changes the model, and
    reading one before ``fit`` raises :class:`NotFittedError`.

    **Constructor convention.** An estimator is built as ``Estimator(config=None,
    fps=120.0)``, both also keywords:

    * ``config``: the method's frozen config dataclass (:class:`~streamseg.config.LOFConfig`,
      :class:`~streamseg.config.ACAConfig`, :class:`~streamseg.config.RepetitionConfig`);
      None: its defaults. Every parameter of the method lives there, validated once, in
      seconds (``*_s`` names) rather than frames, so one config serves any frame rate and
      round-trips through TOML (``streamseg serve --config``) and the command line.
    * ``fps``: the frame rate of what ``fit`` is given (a :class:`~streamseg.recording.Recording`
      brings its own where the method reads recordings), converting the config's seconds to
      frames.

    Anything else (e.g. ``LOFSegmenter``'s ``n_features``) comes after, as a keyword with a
    default. ``LOFSegmenter``, ``ACASegmenter``, ``ACA``, ``HACA`` and
    ``RepetitionSegmenter`` follow it (``tests/test_newcomer.py`` checks their signatures;
    the old ``ACA(n_clusters, min_len_frames, max_len_frames, ...)`` call is refused with a
    message saying the new one). The engines they run,
    :class:`~streamseg.offline.aca.ACAEngine` and :class:`~streamseg.offline.haca.HACAEngine`,
    take lengths in frames and a fixed number of clusters, as the papers state the
    algorithms (:func:`~streamseg.offline.model_selection.model_from_config` builds them
    from an ``ACAConfig`` and ``fps``); use them only when you need the engine itself.
    """

    def __setattr__(self, name, value):
        if name.endswith("_") and not name.startswith("_"):
            self.__dict__.setdefault("_fitted", {})[name] = value
        else:
            object.__setattr__(self, name, value)

    def __getattr__(self, name):  # only called when normal lookup fails
        if name.endswith("_") and not name.startswith("_"):
            fitted = self.__dict__.get("_fitted", {})
            if name in fitted:
                return _copy(fitted[name])
            cls = type(self).__name__
            if not fitted:
                raise NotFittedError(f"{cls}.{name} is not set: call {cls}.fit(X) first")
            raise AttributeError(f"{cls} has no fitted attribute {name!r}")
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def __copy__(self):
        # a copy's fitted attributes are its own: fitting it never changes the original
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        if "_fitted" in self.__dict__:
            new.__dict__["_fitted"] = dict(self.__dict__["_fitted"])
        return new

    def _check_fitted(self) -> None:
        if not self.__dict__.get("_fitted"):
            cls = type(self).__name__
            raise NotFittedError(f"{cls}.predict() before fit(): call {cls}.fit(X) first")

    def predict(self) -> list[Segment]:
        """The segments of the fitted sequence (0-based, end exclusive), tiling its frames."""
        self._check_fitted()
        return [Segment(*s) for s in self.__dict__["_fitted"]["segments_"]]

    def fit_predict(self, X) -> list[Segment]:
        """``fit(X)`` then ``predict()``."""
        return self.fit(X).predict()
