"""Repetition counting."""

from __future__ import annotations

from dataclasses import dataclass

from streamseg.config._base import _check


@dataclass(frozen=True)
class RepetitionConfig:
    """Repetition counting, offline and live (one algorithm: :mod:`streamseg.online.repetition`).

    Distances are between pose feature vectors (bone unit directions in the torso frame, the
    trunk's direction, the pelvis height in thigh lengths), so about radians. Why each
    default is what it is: docs/decisions.md, "Repetitions".

    Parameters
    ----------
    lowpass_hz : float
        Causal low-pass of the pose features (2nd-order Butterworth).
    lowpass_low_rate_hz : float
        ...instead, for streams at ``low_rate_fps`` or less (Kinect, cameras: noisier).
    low_rate_fps : float
        See ``lowpass_low_rate_hz``.
    rate_hz : float
        The loops are tracked at about this frame rate (the features are decimated to it).
    min_amplitude : float
        A repetition takes the pose at least this far from where it started.
    return_ratio : float
        A loop closes when the pose comes back within this share of its farthest distance.
    rise_ratio : float
        ...and then moves away again by this share of the loop's depth (then it is cut).
    rise_min : float
        ...and by at least this much.
    rest_level : float
        The cut goes to the slowest frame within this share of the loop's depth of its return.
    amplitude_ratio : float
        Within a set, a loop closes only once it is this share of the set's typical one.
    max_dissimilarity : float
        Consecutive repetitions are alike when mean DTW distance / amplitude is at most this.
    still_ratio : float
        Frames under this share of a loop's peak speed (rests) count in neither its length nor form.
    resample : int
        Repetitions are compared at this many frames (linear resampling, then DTW).
    spread_ratio : float
        The first two repetitions of a set span at least this share of their pose range...
    start_tempo_ratio : float
        ...and last within this factor of each other (later ones follow any tempo).
    pause_s : float
        A rest this long after a repetition ends its set.
    max_cycle_s : float
        Longest repetition; longer motion without a return is no repetition.
    timeout_cycles : float
        A set ends when no repetition ends within this many times its median duration.
    end_return_ratio : float
        At the end of the stream a last loop counts when it came back within this share.
    extend_edges : bool
        A piece before a set's first repetition or at the stream's end counts if DTW-alike.
    edge_ratio : float
        ...and if it moves at least this share of the repetition next to it.
    resume_dissimilarity : float
        A set ended by an unlike loop goes on when the next set starts within one of its
        repetitions and within this dissimilarity of its last one (0: never).
    fidget_ratio : float
        In a set, a loop unlike the last repetition that moves less than this share of the
        set's median repetition is a fidget in the rest, not the set's end (0: never).
    split_ratio : float
        In a set, a loop at least this many times as long as the set's median repetition is
        cut in two where the pose comes closest back when both pieces are more alike the
        repetition before them than the whole loop (0: never).
    anchor_gap_s : float
        While looking for a set, loops start at speed minima at least this far apart.
    max_anchors : int
        ...and at most this many are followed at once.
    lag_compensation : bool
        Report boundaries corrected by the low-pass filter's delay.
    buffer_s : float
        Feature history kept (the longest look back: a set start, an edge piece).
    """

    lowpass_hz: float = 4.0
    lowpass_low_rate_hz: float = 3.0
    low_rate_fps: float = 60.0
    rate_hz: float = 30.0
    min_amplitude: float = 0.6
    return_ratio: float = 0.65
    rise_ratio: float = 0.35
    rise_min: float = 0.15
    rest_level: float = 0.1
    amplitude_ratio: float = 0.5
    max_dissimilarity: float = 0.6
    still_ratio: float = 0.25
    resample: int = 32
    spread_ratio: float = 0.85
    start_tempo_ratio: float = 2.0
    pause_s: float = 3.0
    max_cycle_s: float = 8.0
    timeout_cycles: float = 3.0
    end_return_ratio: float = 0.6
    extend_edges: bool = True
    edge_ratio: float = 0.4
    resume_dissimilarity: float = 0.3
    fidget_ratio: float = 0.6
    split_ratio: float = 1.6
    anchor_gap_s: float = 0.2
    max_anchors: int = 41
    lag_compensation: bool = True
    buffer_s: float = 20.0

    def __post_init__(self):
        for name in (
            "lowpass_hz",
            "lowpass_low_rate_hz",
            "low_rate_fps",
            "rate_hz",
            "min_amplitude",
            "rise_min",
            "pause_s",
            "max_cycle_s",
            "timeout_cycles",
            "anchor_gap_s",
            "buffer_s",
            "max_dissimilarity",
            "start_tempo_ratio",
        ):
            v = getattr(self, name)
            _check(
                name,
                v,
                isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0,
                "a number > 0",
            )
        for name in (
            "return_ratio",
            "rise_ratio",
            "rest_level",
            "amplitude_ratio",
            "spread_ratio",
            "end_return_ratio",
            "still_ratio",
            "edge_ratio",
            "resume_dissimilarity",
            "fidget_ratio",
        ):
            v = getattr(self, name)
            _check(
                name,
                v,
                isinstance(v, (int, float)) and not isinstance(v, bool) and 0 <= v <= 1,
                "a number in [0, 1]",
            )
        for name in ("resample", "max_anchors"):
            v = getattr(self, name)
            _check(
                name,
                v,
                isinstance(v, int) and not isinstance(v, bool) and v >= 2,
                "an integer >= 2",
            )
        for name in ("extend_edges", "lag_compensation"):
            v = getattr(self, name)
            _check(name, v, isinstance(v, bool), "true or false")
        _check(
            "buffer_s",
            self.buffer_s,
            self.buffer_s >= 2 * self.max_cycle_s,
            f"at least 2 x max_cycle_s ({2 * self.max_cycle_s:g} s)",
        )
