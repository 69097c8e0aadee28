"""What a daemon's streams run: :class:`Algorithms`, the factory of each stream's detectors
and relabel with their configurations, and :func:`algorithms_for`, which completes it from a
:class:`~streamseg.config.DaemonConfig`.

Everything heavy is imported where it is first used, so that a daemon (and ``segment``) loads
only the algorithms it runs.
"""

from __future__ import annotations

import time

import numpy as np

from streamseg.recording import Skeleton

__all__ = ["Algorithms", "algorithms_for"]

SETTLE_S = 8.0  # seconds of frames after a provisional cut a relabel needs to settle it
FOCUS_S = 20.0  # seconds before the oldest open cut a focused relabel's window starts
RADIUS_S = 1.0  # a relabel boundary this close to a provisional cut confirms it


class Algorithms:
    """The algorithms one daemon runs, with their configurations.

    Parameters
    ----------
    lof_config : LOFConfig or None
        Streaming cut detector configuration (None: the library default).
    aca_config : ACAConfig or None
        Windowed relabelling configuration (None: the library default).
    relabel : callable or None
        Replaces :func:`streamseg.offline.relabel_window` (same signature); tests use it to
        make a relabel slow.
    memory_config : LabelMemoryConfig or None
        The exemplar memory that keeps ids beyond the relabel history
        (:mod:`streamseg.offline.label_memory`); None: off (ids carried by overlap only).
    gap_fill_s : float or None
        Longest gap filled by interpolation, seconds (None: the daemon's
        ``DaemonConfig.gap_fill``; outside a daemon :data:`streamseg.io.gaps.FILL_S`).
    settle_s : float or None
        Seconds of frames a relabel needs after a provisional cut to settle it (confirm or
        withdraw it, :mod:`streamseg.daemon.settle`); 0: cuts are not settled and make no
        relabel due. None: the daemon's ``DaemonConfig.settle``, outside a daemon
        :data:`SETTLE_S`.
    focus_s : float or None
        Seconds before the oldest open cut the window of the relabel it makes due starts
        (None: ``DaemonConfig.focus`` in a daemon, else :data:`FOCUS_S`).
    radius_s : float or None
        A relabel boundary within this many seconds of a provisional cut confirms it (None:
        :data:`RADIUS_S`).
    alternations : bool
        Merge a revision's alternations of two labels into one action before it is published
        (:mod:`streamseg.daemon.alternation`; False: HACA's labels as they are).
    markers : MarkerSet or None
        A marker map of the user's own (:func:`streamseg.skeleton.marker_map.load_marker_map`,
        ``--markers MAP.toml``): a stream whose announced joints hold its markers is
        segmented on the joints it makes; other streams as announced.
    """

    def __init__(
        self,
        lof_config=None,
        aca_config=None,
        relabel=None,
        repetitions=False,
        rep_config=None,
        memory_config=None,
        gap_fill_s=None,
        settle_s=None,
        focus_s=None,
        radius_s=None,
        markers=None,
        alternations=True,
    ):
        self.lof_config = lof_config
        self.aca_config = aca_config
        self._relabel = relabel
        self.repetitions = repetitions
        self.rep_config = rep_config
        self.memory_config = memory_config
        self.gap_fill_s = None if gap_fill_s is None else float(gap_fill_s)
        self.settle_s = None if settle_s is None else float(settle_s)
        self.focus_s = None if focus_s is None else float(focus_s)
        self.radius_s = None if radius_s is None else float(radius_s)
        self.markers = markers
        self.alternations = bool(alternations)

    def settlement(self, fps: float):
        """A stream's :class:`~streamseg.daemon.settle.Settlement` (None: settling off)."""
        from streamseg.daemon.settle import Settlement

        settle = SETTLE_S if self.settle_s is None else self.settle_s
        if settle <= 0:
            return None
        focus = FOCUS_S if self.focus_s is None else self.focus_s
        radius = int(round((RADIUS_S if self.radius_s is None else self.radius_s) * fps))
        return Settlement(fps, settle, focus, radius)

    def prepare(self, skeleton: Skeleton):
        """Per-stream feature plan: bone end-point indices, resolved once (raises
        SkeletonError when the skeleton lacks a joint the 8 angles need), the skeleton's
        up vector when the cut detector uses inclinations (else None), both as the
        arguments of the angle kernel (:meth:`StreamingLOFSegmenter.learn_positions`), the
        marker map's columns when it applies (:meth:`joints_of`; else None) and then how
        its lost markers are placed (:func:`streamseg.skeleton.marker_fill.live_layout`;
        None: no clusters or pairs among the stream's markers)."""
        from streamseg.config import LOFConfig
        from streamseg.skeleton.bones import bone_point_indices, up_vector

        names = skeleton.names
        skeleton, columns = self.joints_of(skeleton)
        inclinations = (self.lof_config or LOFConfig()).inclinations
        points = bone_point_indices(skeleton)
        up = up_vector(skeleton.up) if inclinations else None
        layout = None
        if columns is not None:
            from streamseg.skeleton.marker_fill import live_layout
            from streamseg.skeleton.marker_map import stream_markers

            layout = live_layout(self.markers, stream_markers(self.markers, names))
        return points, up, _bone_args(points, up), columns, layout

    def joints_of(self, skeleton: Skeleton):
        """``(skeleton, columns)``: the skeleton a stream's features are computed on and the
        marker map's columns for it (:func:`streamseg.skeleton.marker_map.marker_columns`),
        when ``markers`` is set and the announced joints hold its markers; else the
        announced skeleton and None. Raises SkeletonError when the announced joints are
        neither the map's markers nor a skeleton streamseg knows."""
        if self.markers is None:
            return skeleton, None
        from streamseg.skeleton.marker_map import columns_for
        from streamseg.skeleton.marker_sets import JOINTS, PARENTS

        columns = columns_for(self.markers, skeleton.names)
        if columns is None:
            return skeleton, None
        return Skeleton(
            JOINTS, np.array(PARENTS), np.zeros((len(JOINTS), 3)), skeleton.units, skeleton.up
        ), columns

    def angles(self, positions: np.ndarray, plan) -> np.ndarray:
        """Features ``(n, d)`` of positions ``(n, J, 3)`` (the 8 bone angles, then the 9
        inclinations when the plan has an up vector): :func:`streamseg.skeleton.bones.
        angles_at` with the joint names resolved once per stream in :meth:`prepare` (that
        lookup costs more than the maths for a packet of a few frames)."""
        from streamseg.skeleton.bones import angles_at

        return angles_at(positions, plan[0], plan[1])

    def segmenter(self, fps: float):
        """A fresh streaming cut detector for one stream."""
        from streamseg.config import LOFConfig
        from streamseg.online.lof import StreamingLOFSegmenter

        return StreamingLOFSegmenter(self.lof_config or LOFConfig(), fps)

    def relabel(self, features: np.ndarray, start_frame: int, fps: float):
        """Windowed ACA of ``features`` (m, d); row 0 is learned frame ``start_frame``.

        Cluster ids are the window's own; :func:`relabel` maps the rows to stream frames and
        then makes the ids consistent with the previous relabel (:func:`stable_labels`),
        because rows and stream frames differ wherever frames were missing.
        """
        from streamseg.offline import relabel_window

        fn = self._relabel or relabel_window
        return fn(
            features, start_frame=start_frame, fps=fps, config=self.relabel_config, previous=None
        )

    @property
    def relabel_config(self):
        """The ACA configuration relabelling uses."""
        from streamseg.config import ACAConfig

        return self.aca_config or ACAConfig()

    def root_speed(self, fps: float, skeleton: Skeleton):
        """The stream's root-speed columns (:class:`streamseg.online.root_speed.RootSpeed`),
        or None when the cut detector has none (``LOFConfig.root_speed_max = 0``)."""
        from streamseg.config import LOFConfig

        config = self.lof_config or LOFConfig()
        if not config.root_columns:
            return None
        from streamseg.online.root_speed import RootSpeed

        return RootSpeed(config, fps, skeleton)

    def rep_counter(self, fps: float, skeleton: Skeleton):
        """A live repetition counter for one stream, or None when turned off."""
        if not self.repetitions:
            return None
        from streamseg.online.repetition import RepetitionCounter

        return RepetitionCounter(self.rep_config, fps, skeleton)

    def warmup(self, relabel: bool = True) -> float:
        """Compile and run every kernel once on synthetic data; returns seconds spent."""
        from streamseg.offline.relabel import warmup as warmup_aca
        from streamseg.online.lof import warmup as warmup_lof
        from streamseg.skeleton.bones import angles_at

        t = time.perf_counter()
        warmup_lof()
        if relabel:
            warmup_aca()
        if self.repetitions:
            from streamseg.online.repetition import warmup as warmup_reps

            warmup_reps()
        plan = np.arange(18).reshape(9, 2) % 9
        angles_at(np.zeros((2, 9, 3)), plan)
        angles_at(np.zeros((2, 9, 3)), plan, np.array([0.0, 1.0, 0.0]))
        from streamseg._kernels import root_speed as _kr

        _kr.root_speeds(
            np.ones((2, 9, 3)),
            0,
            plan[1:].astype(np.int64),
            np.array([0.0, 1.0, 0.0]),
            np.array([0, 1]),
            np.zeros((3, 3)),
            np.zeros(3),
            1.0,
            1.0,
            1.0,
            np.empty((2, 2)),
        )
        rng = np.random.default_rng(0)
        # a random walk of angles: enough frames for the LOF windows to fill and cut
        fps = 120.0
        seg = self.segmenter(fps)
        walk = np.clip(
            1.5 + np.cumsum(rng.normal(0, 0.01, (6 * int(fps), seg.n_features)), axis=0), 0, 3
        )
        seg.learn_many(walk)
        seg.finish()
        if relabel:
            # the relabels read the bone features, not the root speeds
            self.relabel(walk[-int(4 * fps) :, : seg.n_features - seg.config.root_columns], 0, fps)
        self._warm_stream(fps, rng)
        return time.perf_counter() - t

    def _warm_stream(self, fps: float, rng) -> None:
        """A stream's own path (gap filler, one kernel call per packet, the counter) on a
        random walk of a Kinect v2 body, so its first packets compile nothing in the loop."""
        from streamseg.daemon.options import skeleton_from
        from streamseg.daemon.pipeline import StreamPipeline
        from streamseg.skeleton.joint_sets import KINECT_V2

        n = len(KINECT_V2.names)
        # as an announce of these joints makes it
        skeleton = skeleton_from(KINECT_V2.names, [-1] * n, KINECT_V2.units, KINECT_V2.up)
        pipe = StreamPipeline(skeleton, fps, self, history=4.0)
        base = rng.normal(0, 0.3, (1, n, 3)) + np.array([0.0, 1.0, 0.0])
        walk = base + np.cumsum(rng.normal(0, 0.002, (3 * int(fps), n, 3)), axis=0)
        walk[10, 3] = np.nan  # a filled gap
        half = walk.shape[0] // 2
        pipe.push(walk[:half], 0)
        pipe.push(walk[half:], half)
        pipe.finish()
        pipe.finish_reps()


def algorithms_for(config, algorithms: Algorithms | None = None) -> Algorithms:
    """The daemon's per-stream algorithms: ``algorithms`` (default: LOF cuts + ACA relabel
    with default configs) with what it leaves unset taken from ``config``. What
    ``Algorithms(...)`` was given wins over the config."""
    algorithms = algorithms or Algorithms(repetitions=config.repetitions)
    if config.label_memory and algorithms.memory_config is None:
        from streamseg.config.memory import LabelMemoryConfig

        # the switch turns the memory on with its defaults; Algorithms(memory_config=...)
        # sets other ones (and turns it on by itself)
        algorithms.memory_config = LabelMemoryConfig()
    if algorithms.gap_fill_s is None:
        algorithms.gap_fill_s = float(config.gap_fill)
    if algorithms.settle_s is None:  # settling needs relabels
        algorithms.settle_s = float(config.settle) if config.relabel_interval > 0 else 0.0
    if algorithms.focus_s is None:
        algorithms.focus_s = float(config.focus)
    if algorithms.markers is None and config.markers:
        from streamseg.skeleton.marker_map import load_marker_map

        algorithms.markers = load_marker_map(config.markers)
    return algorithms


def _bone_args(points: np.ndarray, up) -> tuple:
    """The angle kernel's arguments (:func:`streamseg._kernels.bones.angles_kernel`) for bone
    end points ``points`` (9, 2) and the up vector (None: no inclinations), as
    :func:`streamseg.skeleton.bones.angles_at` passes them."""
    from streamseg.skeleton.bones import ANGLES, INCLINATIONS

    pairs = np.array(ANGLES + (INCLINATIONS if up is not None else ()), dtype=np.int64)
    return (
        np.ascontiguousarray(points[:, 0], dtype=np.int64),
        np.ascontiguousarray(points[:, 1], dtype=np.int64),
        np.ascontiguousarray(pairs[:, 0]),
        np.ascontiguousarray(pairs[:, 1]),
        np.zeros(3) if up is None else np.asarray(up, dtype=np.float64),
    )
