"""The daemon's per-stream pipeline without sockets: features, frame clock, relabel mapping."""

from __future__ import annotations

import numpy as np

from streamseg.daemon.algorithms import Algorithms
from streamseg.daemon.pipeline import StreamPipeline
from streamseg.daemon.relabel_job import relabel
from streamseg.io.gaps import fill_gaps
from streamseg.offline.identity import stable_labels
from streamseg.offline.relabel import WindowSegmentation
from streamseg.online.lof import StreamingLOFSegmenter
from streamseg.online.root_speed import root_speed_columns
from streamseg.skeleton import bone_angles


def test_cached_angles_are_bone_angles(rec):
    alg = Algorithms()
    got = alg.angles(rec.positions[:500], alg.prepare(rec.skeleton))
    want = bone_angles(rec.positions[:500], rec.skeleton, inclinations=True)
    assert got.shape == (500, 17)
    assert np.array_equal(got, want, equal_nan=True)


def test_chunking_and_gaps_keep_stream_frames(rec):
    """Any packet sizes give the offline cuts; a short loss is filled as a file's gap is."""
    pos = rec.positions
    lost = pos.copy()
    lost[1500:1530] = np.nan  # offline, the lost frames are NaN frames ...
    lost, _ = fill_gaps(lost, rec.fps)  # ... filled as the gaps of a file
    assert np.isfinite(lost).all()
    ref = bone_angles(lost, rec.skeleton, inclinations=True)
    seg = StreamingLOFSegmenter(fps=rec.fps)
    ref = np.column_stack([ref, root_speed_columns(lost, rec.skeleton, rec.fps)])
    want = [(c.frame, c.emitted_at) for c in seg.learn_many(ref) + seg.finish()]
    p = StreamPipeline(rec.skeleton, rec.fps, Algorithms(), history=5.0)
    got, a, rng = [], 0, np.random.default_rng(1)
    while a < rec.n_frames:
        if a == 1500:
            a = 1530  # frames 1500..1529 are lost
        b = min(a + int(rng.integers(1, 200)), rec.n_frames)
        if a < 1500 < b:
            b = 1500
        cuts, _, _ = p.push(pos[a:b], a)
        got += [(f, e) for f, _, e, _ in cuts]
        a = b
    got += [(f, e) for f, _, e, _ in p.finish()]
    assert got == want
    feats, frames = p.snapshot()
    assert feats.shape == (600, 17) and np.array_equal(
        frames, np.arange(rec.n_frames - 600, rec.n_frames)
    )
    assert np.allclose(feats, ref[-600:, :17], atol=1e-6)  # float32 ring, no root speeds


def test_nan_frames_are_skipped_in_the_ring_and_mapped_back(rec):
    pos = rec.positions[:400].copy()
    pos[100:160] = np.nan  # 0.5 s: longer than the gap filler fills
    pos[300:305] = np.nan  # filled
    p = StreamPipeline(rec.skeleton, rec.fps, Algorithms(), history=10.0)
    _, _, bad = p.push(pos, 0)
    assert bad == 60 and p.gaps == [(100, 160)]
    feats, frames = p.snapshot()
    assert feats.shape[0] == 340 and 100 not in frames and frames[100] == 160

    def fake(features, *, start_frame, fps, config, previous):
        n = features.shape[0]  # rows, not frames: two segments split at row 100
        return WindowSegmentation(
            start_frame,
            start_frame + n,
            [(start_frame, start_frame + 100, 0), (start_frame + 100, start_frame + n, 1)],
        )

    out = relabel(Algorithms(relabel=fake), feats, frames, 120.0, None)
    assert (out.start, out.end) == (0, 400)
    assert out.segments == ((0, 100, 0), (160, 400, 1))


def test_stable_labels_follow_the_previous_window():
    prev = WindowSegmentation(0, 100, [(0, 50, 3), (50, 100, 7)])
    new = WindowSegmentation(50, 150, [(50, 100, 0), (100, 120, 1), (120, 150, 2)])
    out = stable_labels(new, prev)
    labels = [lab for _, _, lab in out.segments]
    assert labels[0] == 7  # same frames as the old cluster 7
    assert len(set(labels)) == 3 and not {3, 7} & set(labels[1:])


def test_labels_stay_stable_across_missing_frames():
    """Rows and stream frames differ where frames were missing (NaN frames, lost packets);
    ids must be matched in stream frames. Revision 1 covers frames 0-99 and 200-299 (100-199
    missing), all one cluster; revision 2 covers 200-399 with the same action."""

    def one_cluster(features, *, start_frame, fps, config, previous):
        n = features.shape[0]
        return WindowSegmentation(start_frame, start_frame + n, [(start_frame, start_frame + n, 0)])

    algorithms = Algorithms(relabel=one_cluster)
    frames1 = np.concatenate([np.arange(0, 100), np.arange(200, 300)])
    first = relabel(
        algorithms, np.zeros((200, 8)), frames1, 120.0, WindowSegmentation(0, 300, [(0, 300, 5)])
    )
    assert {lab for _, _, lab in first.segments} == {5}
    second = relabel(algorithms, np.zeros((200, 8)), np.arange(200, 400), 120.0, first.window)
    assert second.segments == ((200, 400, 5),)


# run in a fresh interpreter: a kernel version an earlier test compiled in this process would
# hide one the warm-up misses
_WARM_THEN_STREAM = """
import importlib, json, pkgutil, sys
import numpy as np
import streamseg._kernels as kernels
from streamseg.daemon.algorithms import Algorithms
from streamseg.daemon.pipeline import StreamPipeline
from streamseg.daemon.state_codec import dump, load, packable, stored
from streamseg.io import read

rec = read(sys.argv[1], skeleton=sys.argv[2])
algorithms = Algorithms(repetitions=True)
algorithms.warmup(relabel=False)
modules = [importlib.import_module(f"streamseg._kernels.{m.name}")
           for m in pkgutil.iter_modules(kernels.__path__)]

def compiled():
    return {f"{m.__name__}.{k}": len(v.signatures) for m in modules
            for k, v in vars(m).items() if hasattr(v, "signatures")}

before = compiled()
pos = rec.positions[:2400].copy()
pos[700:720, 4] = np.nan
frozen = pos.copy()
frozen.flags.writeable = False
p = StreamPipeline(rec.skeleton, rec.fps, algorithms, history=10.0)
cuts = []
for a in range(0, 1200, 100):
    cuts += p.push((frozen if a % 200 else pos)[a:a + 100], a)[0]
chunks = {}
packed = packable(dump(p), chunks)
p = load(packed, {d: stored(c) for d, c in chunks.items()})
p.algorithms, p.plan = algorithms, algorithms.prepare(p.skeleton)
for a in range(1200, 2400, 100):
    cuts += p.push((frozen if a % 200 else pos)[a:a + 100], a)[0]
cuts += p.finish()
p.finish_reps()
print(json.dumps({"cuts": len(cuts), "before": before, "after": compiled()}))
"""


def test_warmup_compiles_everything_a_stream_runs(data_dir):
    """After the daemon's warm-up, a real take through a stream's pipeline compiles nothing
    (a compile in the loop stalls every stream and control request for seconds): read-only
    packets as decoded, writable ones as joined, a gap, and a pipeline restored from its
    checkpoint, as after a restart."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    out = subprocess.run(
        [
            sys.executable,
            "-c",
            _WARM_THEN_STREAM,
            str(data_dir / "cmu86" / "86_01.amc.gz"),
            str(data_dir / "cmu86" / "86.asf"),
        ],
        capture_output=True,
        text=True,
        cwd=Path(__file__).parents[1],
        check=True,
    )
    got = json.loads(out.stdout.splitlines()[-1])
    assert got["cuts"] > 0, "the take has cuts: the cut path ran"
    assert got["after"] == got["before"]
