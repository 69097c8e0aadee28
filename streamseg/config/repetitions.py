"""Repetition segmentation."""

from __future__ import annotations

from dataclasses import dataclass

from streamseg.config._base import _check


@dataclass(frozen=True)
class RepetitionConfig:
    """Repetition segmentation (Wang et al. 2015) offline and live.

    Parameters
    ----------
    position_noise : float
        UKF measurement noise std in body-scale units (1 = the median long-bone length);
        0.05 is about 1.5 cm on an adult: between optical mocap and Kinect.
    angle_speed : float
        UKF random-walk std of each joint angle, rad per second.
    estimate_noise : bool
        Offline: raise ``position_noise`` to the noise estimated from the recording's
        frame-to-frame jitter (:func:`streamseg.kinematics.model.estimate_noise`) when larger.
    length_speed : float
        UKF random-walk std of log bone lengths per second (passes 1-2).
    ukf_passes : int
        4 (paper) or 2 (skip the fixed-length passes).
    torso_cutoff_hz : float
        Low-pass applied to the points defining the torso frame.
    power_ratio : float
        theta: the selected parameters hold this share of the power at the primary frequency.
    min_cycles : float
        Lowest primary frequency, in cycles per sequence.
    max_frequency_hz : float
        Highest primary frequency (repetitions per second).
    fft_pad : int
        Zero-padding factor of the spectra.
    band_width_cycles : float
        Width of the band around the primary frequency whose share of the power is the
        concentration (the live "repetitive" test), cycles per sequence.
    bandpass_width_cycles : float
        Width of the Butterworth band-pass around the primary frequency, cycles per sequence
        (paper: 3; 6 was chosen on the dev set, the middle of the 4-8 plateau there: a narrow
        band spaces the candidates evenly whatever the repetitions' own lengths). A band
        reaching 0 becomes a low-pass.
    filter_order : int
        Butterworth order.
    window_fraction : float
        Candidate-search window (eq. 10) as a fraction of the period; windows overlap by half.
    k_max : int
        Largest K tried by the adaptive k-means (paper: 10).
    kmeans_restarts : int
    seed : int
    tie_tolerance : float
        Groups whose eq. 14 span is within this fraction of the best count as tied (0.1,
        chosen on the dev set: on short sequences a group missing only an edge point loses
        several percent of span).
    edge_fraction : float
        A stretch before the first / after the last boundary is a repetition when at least this
        many periods long (0.7, chosen on the dev set with ``merge_edges``).
    merge_edges : bool
        Offline: a shorter stretch is the rest of the first / last repetition (the boundary
        point is taken for the sequence's start / end) instead of frames outside every
        repetition: the sequence is taken to start and end at repetition boundaries.
    merge_phase : float
        k-means clusters whose mean cos(phase) vectors are closer than this (RMS; opposite
        phases are ~2 apart) are merged into one group before eq. 14 (0 = never merge).
    refine_fraction : float
        Each chosen boundary moves to the frame nearest the rest pose (``refine_to``) of the
        selected parameters low-passed at ``refine_band`` x the primary frequency, within
        this many periods (0 = off: the paper's boundaries).
    refine_band : float
        Low-pass cut-off of that refinement, in multiples of the primary frequency.
    refine_to : {"rest", "speed"}
        What the refinement looks for: "rest", the pose nearest the rest pose (the selected
        parameters at the sequence's ends, low-passed as above; where a repetition starts and
        ends), or "speed", the smallest squared velocity. Chosen on actor bd alone with
        ``refine_fraction`` 0.4 (``benchmarks/repetitions.py``): "rest" raised bd's alpha
        from 0.887 to 0.958 and its exact counts from 0.90 to 1.00.
    min_concentration : float
        Offline "repetitive" test: the band around the primary frequency holds at least this
        share of the power above ``min_cycles`` (0.2: the bd sequences reach 0.34 or more,
        white noise a few percent).
    max_subharmonic : float
        Offline and live "repetitive" test: power at half the primary frequency below this
        multiple of the power at it (0.5; bd's repetitive sequences <= 0.25, its single
        clips, one repetition or one action, >= 0.9: their "primary" is a harmonic of the
        one movement).
    still_std : float
        A take whose every analysed parameter varies less than this (standard deviation;
        bone unit directions, so about radians: 0.6 degrees) holds no motion.
    live_refine_fraction : float
        Live: ``refine_fraction`` of the live counter, whose refinement always looks for
        velocity minima (a live buffer's ends are no rest pose).
    buffer_s : float
        Live: analysed history.
    hop_s : float
        Live: analysis interval.
    align : {"dtw", "none"}
        Offline: "dtw" re-cuts the repetitions found by the steps above into consecutive
        pieces aligned by DTW to a template repetition (their medoid;
        :mod:`streamseg.offline.rep_align`), so that repetitions of different lengths (a pause
        before one hop, a slower kick) keep their own boundaries; "none" keeps the spectral
        boundaries (and is what the live counter does). Chosen on actor bd alone (two draws,
        30 sequences; ``benchmarks/repetitions.py``, ALIGN_GRID) and then held out once on bk
        and dg: clean alpha 0.875 -> 0.911 and exact counts 0.83 -> 0.97; Kinect-like alpha
        0.839 -> 0.836 (a tie) and exact counts 0.83 -> 0.90. It costs bd's own clean alpha
        0.961 -> 0.942 (arm circles), and on bd's first draw alone "none" scores higher.
    align_features : {"selected", "all"}
        What the alignment compares: the selected parameters or every analysed one, low-passed
        at ``refine_band`` x the primary frequency ("selected", chosen on bd).
    align_stretch : float
        Each aligned piece is between 1 / this and this times the median repetition length
        (1.5-3 scored alike on bd; not chosen by grid).
    align_rate_hz : float
        The alignment runs at about this frame rate (subsampled; cost grows with the cube of
        the frames per repetition); cuts are then snapped at full rate (``align_snap``).
    align_iterations : int
        Template -> re-cut rounds (the template is re-chosen from the new pieces).
    align_max_slope : int
        Most sequence frames per template frame in one DTW step: the path's slope stays
        within [1/2, this], so a stretch of the sequence is never squeezed onto one template
        frame (without it, an odd first repetition was absorbed by its neighbour at no
        cost). 3, chosen on bd (2 or 3 in the grid).
    align_max_compress : int
        Most template frames per sequence frame in one DTW step: a piece may be as short as
        1 / this of the template. 2 (the limit before it was a setting). Repetitions that
        differ in their rest, not their movement (dg's two-leg hops: 70-85 and 138-151
        frames in one set) might need the template's rest squeezed more than 2x: in issue
        14's round 9 diagnosis (``benchmarks/rep_diagnosis.py --counts``, draws 0-5 of bd, bk
        and dg) pieces merging two true repetitions were the commonest wrong count. Grid
        {2, 3, 4} on those draws (270 sequences per condition): alpha clean / Kinect-like
        0.901 / 0.855 (exact counts 0.92 / 0.87) at 2, 0.898 / 0.859 (0.93 / 0.90) at 3,
        0.894 / 0.854 (0.93 / 0.90) at 4: 3 ties 2 on the declared score (mean alpha within
        0.001), so 2 stays and nothing was held out. It fixes Kinect-like merges of bd and bk
        (hops, arm circles) but not dg's hops, where the tiling objective itself prefers the
        wrong count (``--objective``).
    align_snap : float
        Each aligned cut then moves to the frame nearest the rest pose within this fraction
        of its shorter neighbouring piece (0 = off; 0.3, chosen on bd from 0 or 0.3): a
        template starts and ends at rest, so a cut may otherwise sit anywhere in a pause.
    align_snap_level : float
        0 (the default): the snap puts each cut on the frame nearest the rest pose. Above 0
        it puts it at ``align_snap_position`` of the pause around that frame: the frames in
        the snap window whose squared distance to the rest pose stays within this share of
        the window's range above its minimum. On bd the true joins (the HDM05 authors' clip
        cuts) sit after the frame nearest the rest pose, at 0.56-0.67 of such a pause
        (median; the snapped cut was 0.028 / 0.045 of a repetition early, clean /
        Kinect-like). 0.05 with position 0.6 was chosen on bd alone (draws 0-1, a 26-point
        grid with ``align_snap``; ``benchmarks/rep_boundaries.py``): bd alpha 0.941 -> 0.944
        clean, 0.935 -> 0.944 Kinect-like; held out once (bk + dg, fresh draws 6-9, 120
        sequences per condition, ``benchmarks/rep_heldout.py``) 0.854 -> 0.860 clean, 0.820
        -> 0.830 Kinect-like, exact counts unchanged (a snap moves inner cuts only). It stays
        off: on bd's labelled routine (``tests/test_rep_eval_sets.py``) one hop piece that
        overruns into the throw take then has its middle there (the throw counted 1, not 0)
        and the four sets' alpha drop by 0.003-0.018 (issue 14, round 8).
    align_snap_position : float
        Where in that pause the cut goes: 0 its first frame, 0.5 its middle, 1 its last.
    root_height_weight : float
        0 (off): the analysed parameters are the 30 bone directions. Above 0 a 31st
        column is added: the pelvis height relative to its median over the take, in
        body-scale units (1 = the median long-bone length), times this weight
        (:func:`streamseg.offline.root_height.with_root_height`; recordings only, an array is
        analysed as given). The spectrum, the parameter selection and the DTW template all
        see it. Why: the bone directions carry no height, so a bounce (hip +7..13 cm) followed
        by a hop (+19..30 cm) looks like two short hops (issue 14, round 9: dg's two-leg
        hops, 12 of 18 counted too few clean). Off by default: grid {1, 2, 4} on draws 0-5
        of bd, bk and dg (270 sequences per condition; ``benchmarks/rep_heldout.py
        --choose-on none``), alpha clean / Kinect-like and exact counts (of 270):
        0 0.901 / 0.855 (249 / 235), 1 0.902 / 0.857 (250 / 237), 2 0.903 / 0.863 (250 /
        239), 4 0.905 / 0.865 (248 / 238). The declared rule chose 4 (best mean alpha, 0.0017
        above 2), and 4 counts one clean sequence fewer exactly than 0, so nothing was held
        out (issue 14, round 10). dg gains (Kinect-like 0.784 -> 0.824 at 4), bk loses
        (0.860 -> 0.845); the tiling objective still prefers dg's wrong hop pieces, with the
        height in the template too.
    repetitive_ratio : float
        Routines (:mod:`streamseg.offline.sets`): a take whose power concentration reaches
        this (and that passes the repetitive test) is one exercise, one set, and is not cut
        into actions.
    """

    position_noise: float = 0.05
    angle_speed: float = 8.0
    estimate_noise: bool = True
    length_speed: float = 0.02
    ukf_passes: int = 4
    torso_cutoff_hz: float = 2.0
    power_ratio: float = 0.9
    min_cycles: float = 2.0
    max_frequency_hz: float = 3.0
    fft_pad: int = 4
    band_width_cycles: float = 3.0
    bandpass_width_cycles: float = 6.0
    filter_order: int = 2
    window_fraction: float = 0.5
    k_max: int = 10
    kmeans_restarts: int = 5
    seed: int = 0
    tie_tolerance: float = 0.1
    edge_fraction: float = 0.7
    merge_phase: float = 0.6
    refine_fraction: float = 0.4
    refine_band: float = 4.0
    merge_edges: bool = True
    refine_to: str = "rest"
    min_concentration: float = 0.2
    max_subharmonic: float = 0.5
    still_std: float = 0.01
    live_refine_fraction: float = 0.2
    buffer_s: float = 12.0
    hop_s: float = 0.5
    repetitive_ratio: float = 0.5
    align: str = "dtw"
    align_features: str = "selected"
    align_stretch: float = 2.0
    align_rate_hz: float = 30.0
    align_iterations: int = 2
    align_snap: float = 0.3
    align_max_slope: int = 3
    align_max_compress: int = 2
    align_snap_level: float = 0.0
    align_snap_position: float = 0.5
    root_height_weight: float = 0.0

    def __post_init__(self):
        for name in (
            "position_noise",
            "angle_speed",
            "torso_cutoff_hz",
            "max_frequency_hz",
            "band_width_cycles",
            "bandpass_width_cycles",
            "buffer_s",
            "hop_s",
        ):
            v = getattr(self, name)
            _check(name, v, isinstance(v, (int, float)) and v > 0, "a number > 0")
        _check(
            "length_speed",
            self.length_speed,
            isinstance(self.length_speed, (int, float)) and self.length_speed >= 0,
            "a number >= 0",
        )
        _check("ukf_passes", self.ukf_passes, self.ukf_passes in (2, 4), "2 or 4")
        for name in ("power_ratio", "repetitive_ratio", "window_fraction"):
            v = getattr(self, name)
            _check(name, v, isinstance(v, (int, float)) and 0 < v <= 1, "a number in (0, 1]")
        _check(
            "min_cycles",
            self.min_cycles,
            isinstance(self.min_cycles, (int, float)) and self.min_cycles >= 1,
            "a number >= 1 (cycles per sequence)",
        )
        for name in ("fft_pad", "filter_order", "kmeans_restarts"):
            v = getattr(self, name)
            _check(name, v, isinstance(v, int) and v >= 1, "an integer >= 1")
        _check(
            "k_max",
            self.k_max,
            isinstance(self.k_max, int) and 2 <= self.k_max <= 50,
            "an integer in 2..50",
        )
        _check("seed", self.seed, isinstance(self.seed, int), "an integer")
        _check("refine_to", self.refine_to, self.refine_to in ("speed", "rest"),
               '"speed" or "rest"')
        for name in ("min_concentration", "still_std"):
            v = getattr(self, name)
            _check(name, v, isinstance(v, (int, float)) and 0 <= v < 1, "a number in [0, 1)")
        _check("max_subharmonic", self.max_subharmonic,
               isinstance(self.max_subharmonic, (int, float)) and self.max_subharmonic > 0,
               "a number > 0")
        _check("align", self.align, self.align in ("dtw", "none"), '"dtw" or "none"')
        _check("align_features", self.align_features,
               self.align_features in ("selected", "all"), '"selected" or "all"')
        _check("align_stretch", self.align_stretch,
               isinstance(self.align_stretch, (int, float)) and self.align_stretch > 1,
               "a number > 1")
        _check("align_rate_hz", self.align_rate_hz,
               isinstance(self.align_rate_hz, (int, float)) and self.align_rate_hz > 0,
               "a number > 0 (Hz)")
        _check("align_iterations", self.align_iterations,
               isinstance(self.align_iterations, int) and self.align_iterations >= 1,
               "an integer >= 1")
        _check("align_max_slope", self.align_max_slope,
               isinstance(self.align_max_slope, int) and self.align_max_slope >= 1,
               "an integer >= 1")
        _check("align_max_compress", self.align_max_compress,
               isinstance(self.align_max_compress, int) and self.align_max_compress >= 1,
               "an integer >= 1")
        _check("align_snap", self.align_snap,
               isinstance(self.align_snap, (int, float)) and 0 <= self.align_snap < 0.5,
               "a number in [0, 0.5)")
        _check("align_snap_level", self.align_snap_level,
               isinstance(self.align_snap_level, (int, float)) and 0 <= self.align_snap_level < 1,
               "a number in [0, 1)")
        _check("align_snap_position", self.align_snap_position,
               isinstance(self.align_snap_position, (int, float))
               and 0 <= self.align_snap_position <= 1, "a number in [0, 1]")
        _check("root_height_weight", self.root_height_weight,
               isinstance(self.root_height_weight, (int, float)) and self.root_height_weight >= 0,
               "a number >= 0 (0 = off)")
        _check("merge_edges", self.merge_edges, isinstance(self.merge_edges, bool), "True or False")
        _check(
            "tie_tolerance",
            self.tie_tolerance,
            isinstance(self.tie_tolerance, (int, float)) and 0 <= self.tie_tolerance < 1,
            "a number in [0, 1)",
        )
        _check(
            "edge_fraction",
            self.edge_fraction,
            isinstance(self.edge_fraction, (int, float)) and 0 < self.edge_fraction <= 1.5,
            "a number in (0, 1.5]",
        )
        _check(
            "merge_phase",
            self.merge_phase,
            isinstance(self.merge_phase, (int, float)) and 0 <= self.merge_phase <= 2,
            "a number in [0, 2]",
        )
        _check(
            "refine_fraction",
            self.refine_fraction,
            isinstance(self.refine_fraction, (int, float)) and 0 <= self.refine_fraction < 0.5,
            "a number in [0, 0.5)",
        )
        _check("live_refine_fraction", self.live_refine_fraction,
               isinstance(self.live_refine_fraction, (int, float))
               and 0 <= self.live_refine_fraction < 0.5, "a number in [0, 0.5)")
        _check(
            "refine_band",
            self.refine_band,
            isinstance(self.refine_band, (int, float)) and self.refine_band >= 1,
            "a number >= 1",
        )
        _check(
            "hop_s",
            self.hop_s,
            self.hop_s < self.buffer_s,
            f"less than buffer_s={self.buffer_s}",
        )
