"""Start-up, reading and the live repetition counter.

``streamseg --help`` in a fresh interpreter (median of 5); 86_01 read from its AMC text
(parse + forward kinematics) and from streamseg's ``.npz`` (median of 5); the formats of
data/sources read by ``streamseg.io.read`` (parse, joint map, gap filling; median of 5):
CMU 01_01 as C3D markers, AMC and BVH, a Qualisys C3D, an OpenCap TRC, a Kinect CSV; the live
repetition counter (:class:`streamseg.online.RepetitionCounter`, its public API: one
``learn_many`` per 4-frame packet of 86_01's joint positions), microseconds per frame.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile

from ._harness import DATA, median_time, recording


def track_help_seconds():
    cmd = [sys.executable, "-m", "streamseg.cli", "--help"]
    subprocess.run(cmd, check=True, capture_output=True)
    return median_time(lambda: subprocess.run(cmd, check=True, capture_output=True), 5)


track_help_seconds.unit = "s"


#: (key, file under data/sources, read options): the reading speed of each format
SOURCES = [
    ("c3d_vicon_01_01", "c3d/cmu_01_01.c3d", {}),
    ("amc_01_01", "cmu01/01_01.amc.gz", {"skeleton": "cmu01/01.asf"}),
    ("bvh_01_01", "bvh/cc_01_01.bvh.gz", {}),
    ("c3d_qualisys", "c3d/qualisys_isb.c3d", {}),
    ("trc_opencap", "trc/opencap_walk.trc", {}),
    ("csv_kinect", "keraal/kinect_ctk.csv", {"joints": "kinect", "fps": 30}),
]


class Read:
    number = repeat = rounds = 1
    timeout = 300

    def setup_cache(self):
        from pathlib import Path

        from streamseg.io import read, write_npz

        amc, asf = DATA / "cmu86" / "86_01.amc.gz", DATA / "cmu86" / "86.asf"
        rec = read(amc, skeleton=asf)
        with tempfile.TemporaryDirectory() as tmp:
            npz = Path(tmp) / "86_01.npz"
            write_npz(npz, rec)
            out = {
                "amc": median_time(lambda: read(amc, skeleton=asf), 5),
                "npz": median_time(lambda: read(npz), 5),
            }
        src = DATA / "sources"
        for key, path, kw in SOURCES:
            out[key] = median_time(
                lambda p=src / path, kw=kw: read(
                    p, **{k: src / v if k == "skeleton" else v for k, v in kw.items()}
                ),
                5,
            )
        return out

    def track_amc_seconds(self, cache):
        return cache["amc"]

    track_amc_seconds.unit = "s"

    def track_npz_ms(self, cache):
        return cache["npz"] * 1e3

    track_npz_ms.unit = "ms"

    def track_source_ms(self, cache, source):
        return cache[source] * 1e3

    track_source_ms.unit = "ms"
    track_source_ms.params = [[key for key, _, _ in SOURCES]]
    track_source_ms.param_names = ["source"]


def track_rep_counter_us_per_frame():
    import time

    from streamseg.online import RepetitionCounter

    rec = recording()
    counter = RepetitionCounter(None, rec.fps, rec.skeleton)
    counter.learn_many(rec.positions)  # every kernel compiled or loaded: its sets' too
    counter = RepetitionCounter(None, rec.fps, rec.skeleton)
    t = time.perf_counter()
    for a in range(0, rec.n_frames, 4):
        counter.learn_many(rec.positions[a : a + 4])
    return (time.perf_counter() - t) / rec.n_frames * 1e6


track_rep_counter_us_per_frame.unit = "us/frame"
track_rep_counter_us_per_frame.timeout = 600
