"""Speed of LOF cut detection, median of 5 runs, each beside the scikit-learn equivalent.

* offline: a 10,000-frame recording (CMU 86_01 + 14_14 + the start of 14_20 joined, real
  data, 120 Hz), joint positions -> bone features (the default: 8 angles + 9 inclinations
  + 2 root speeds) -> histograms -> LOF -> cuts. The paper
  reports about 1.2 s for 8,000-10,000 frames; target here < 50 ms after compilation.
  Baseline: the same pipeline with ``sklearn.neighbors.LocalOutlierFactor(metric="cosine")``
  in place of the numba LOF.
* streaming: joint positions -> bone angles -> StreamingLOFSegmenter -> events, through
  ``learn_many`` on 120-frame packets (target >= 100,000 frames/s) and ``learn_one`` frame
  by frame (bone angles per frame included, and without them). Baseline: the same stream
  with a scikit-learn LOF refit on the buffered windows each time a window completes.

* steady state (``--steady``): CMU 86_01's bone angles cycled to 60,000 frames (8.3 min),
  ``learn_many`` on 120-frame packets; microseconds per frame while the default 75 s buffer
  fills and after it is full (each window then inserts one point and evicts one), and the
  same for 15 and 30 s buffers; median of 3 runs. This is the per-stream cost a long-running
  daemon pays.

* speed columns (``--speed-columns``): the defaults against ``LOFConfig(speed_max=0)`` (the
  detector without the angular-speed columns), interleaved run by run, median of 25.
* novelty check (``--novelty``): the defaults against ``LOFConfig(novelty=0)``, the same way.
* root speeds (``--root-speeds``): the defaults against ``LOFConfig(root_speed_max=0)``, the
  same way (from positions: the root speeds computed per packet as the daemon does).
* two stages (``--two-stage``): ``LOFConfig(early_delay_s=1.2)`` (pending cuts at 1.2 s,
  confirmed at the default 1.5 s) against the defaults (one stage), the same way.

Run: .venv/bin/python benchmarks/lof_speed.py      (about half a minute)
     .venv/bin/python benchmarks/lof_speed.py --steady      (about 20 s)
     .venv/bin/python benchmarks/lof_speed.py --speed-columns      (about a minute)
     .venv/bin/python benchmarks/lof_speed.py --novelty      (about a minute)
     .venv/bin/python benchmarks/lof_speed.py --two-stage      (about a minute)
     .venv/bin/python benchmarks/lof_speed.py --root-speeds      (about a minute)
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from streamseg._kernels.peaks import peak_windows  # noqa: E402
from streamseg.config import LOFConfig  # noqa: E402
from streamseg.evaluation.datasets import concatenate  # noqa: E402
from streamseg.io import read  # noqa: E402
from streamseg.offline.lof import LOFSegmenter, lof_features, window_histograms  # noqa: E402
from streamseg.online.lof import StreamingLOFSegmenter, warmup  # noqa: E402
from streamseg.online.root_speed import RootSpeed  # noqa: E402
from streamseg.skeleton import bone_angles  # noqa: E402

DATA = ROOT / "data"
N = 10_000
RUNS = 5
PACKET = 120


def recording():
    asf = DATA / "cmu86" / "86.asf"
    parts = [read(DATA / "cmu86" / "86_01.amc.gz", skeleton=asf),
             read(DATA / "cmu_exercise" / "14_14.amc.gz", skeleton=asf),
             read(DATA / "cmu_exercise" / "14_20.amc.gz", skeleton=asf)]
    rec, _ = concatenate(parts)
    return rec.slice(0, N)


def median_time(fn, runs=RUNS):
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def offline_ours(rec, cfg):
    return LOFSegmenter(cfg, rec.fps).fit(rec).cuts_


def packet_features(rec, cfg):
    """A function of a packet of positions -> the detector's features, stateful as a live
    stream's (the bone features, then the root speeds when ``cfg`` has them)."""
    root = RootSpeed(cfg, rec.fps, rec.skeleton) if cfg.root_columns else None

    def feats(positions):
        a = bone_angles(positions, rec.skeleton, inclinations=cfg.inclinations)
        return a if root is None else np.column_stack([a, root(positions)])

    return feats


def offline_sklearn(rec, cfg):
    from sklearn.neighbors import LocalOutlierFactor

    g = cfg.frames(rec.fps)
    a = lof_features(rec, cfg)
    counts, centres, _ = window_histograms(a, g["window"], g["step"], cfg.bins, g["min_valid"])
    lof = -LocalOutlierFactor(n_neighbors=cfg.k, metric="cosine").fit(
        counts).negative_outlier_factor_
    w = peak_windows(lof, g["delay"], cfg.dp_tolerance, cfg.threshold_mads, cfg.min_score,
                     g["min_gap"])
    return centres[w]


def stream_many(rec, cfg):
    det = StreamingLOFSegmenter(cfg, rec.fps)
    feats = packet_features(rec, cfg)
    ev = []
    for i in range(0, rec.n_frames, PACKET):
        ev += det.learn_many(feats(rec.positions[i:i + PACKET]))
    return ev + det.finish()


def stream_one(rec, cfg, angles=None):
    det = StreamingLOFSegmenter(cfg, rec.fps)
    ev = []
    if angles is None:
        feats = packet_features(rec, cfg)
        for i in range(rec.n_frames):
            ev += det.learn_one(feats(rec.positions[i:i + 1])[0])
    else:
        for row in angles:
            ev += det.learn_one(row)
    return ev + det.finish()


def stream_sklearn(rec, cfg):
    """Same stream, scikit-learn LOF refit on the buffer at every completed window."""
    from sklearn.neighbors import LocalOutlierFactor

    g = cfg.frames(rec.fps)
    win, step, cap, delay = g["window"], g["step"], g["capacity"], g["delay"]
    edges_scale = cfg.bins / np.pi
    d = cfg.n_features
    ring = np.zeros((win, d), dtype=np.int64)
    cur = np.zeros(d * cfg.bins)
    buf, n_cuts, f = [], 0, 0
    offs = np.arange(d) * cfg.bins
    feats = packet_features(rec, cfg)
    for i in range(0, rec.n_frames, PACKET):
        for row in feats(rec.positions[i:i + PACKET]):
            b = np.minimum((row * edges_scale).astype(np.int64), cfg.bins - 1) + offs
            if f >= win:
                np.subtract.at(cur, ring[f % win], 1)
            ring[f % win] = b
            np.add.at(cur, b, 1)
            if f >= win - 1 and (f - win + 1) % step == 0:
                buf.append(cur.copy())
                buf = buf[-cap:]
                if len(buf) > delay + 1:
                    lof = -LocalOutlierFactor(n_neighbors=min(cfg.k, len(buf) - 1),
                                              metric="cosine").fit(
                        np.array(buf)).negative_outlier_factor_
                    n_cuts += int(len(peak_windows(lof[-2 * delay - 1:], delay,
                                                   cfg.dp_tolerance, cfg.threshold_mads,
                                                   cfg.min_score, g["min_gap"])) > 0)
            f += 1
    return n_cuts


def steady_state(buffers=(15.0, 30.0, 75.0), n=60_000, runs=3):
    """us/frame while the buffer fills and once it is full, 86_01 angles cycled."""
    asf = DATA / "cmu86" / "86.asf"
    rec = read(DATA / "cmu86" / "86_01.amc.gz", skeleton=asf)
    a = lof_features(rec)
    angles = np.ascontiguousarray(np.tile(a, (n // len(a) + 1, 1))[:n])
    warmup()
    print(f"steady state: 86_01 bone angles cycled to {n} frames at {rec.fps:g} Hz, "
          f"learn_many({PACKET}), median of {runs} runs")
    print(f"{'buffer':>8s} {'windows':>8s} {'filling us/frame':>17s} {'full us/frame':>14s} "
          f"{'full frames/s':>14s} {'LOF updates/window':>19s}")
    for b in buffers:
        cfg = LOFConfig(buffer_s=b)
        fill, full = [], []
        for _ in range(runs):
            det = StreamingLOFSegmenter(cfg, rec.fps)
            g = det.geometry
            full_at = g["capacity"] * g["step"] + g["window"]  # first frame with a full buffer
            t_fill = t_full = 0.0
            n_fill = n_full = 0
            for i in range(0, n, PACKET):
                t = time.perf_counter()
                det.learn_many(angles[i:i + PACKET])
                dt = time.perf_counter() - t
                if i + PACKET <= full_at:
                    t_fill, n_fill = t_fill + dt, n_fill + PACKET
                elif i > full_at:
                    t_full, n_full = t_full + dt, n_full + PACKET
            fill.append(t_fill / n_fill * 1e6)
            full.append(t_full / n_full * 1e6)
        per_full = float(np.median(full))
        print(f"{b:7g}s {g['capacity']:8d} {np.median(fill):17.3f} {per_full:14.3f} "
              f"{1e6 / per_full:14,.0f} {det.n_lof_updates_ / det.n_windows_:19.1f}")


def speed_columns_cost(runs=25, n=60_000, cfgs=None, what="speed columns"):
    """The angular-speed columns' cost: the defaults against ``speed_max = 0`` (the detector
    without them, the same code path otherwise), interleaved run by run so machine load hits
    both alike; the ratio is of medians. ``cfgs`` (two labelled configs, the first measured
    against the second) compares another option the same way (``--novelty``)."""
    rec = recording()
    r86 = read(DATA / "cmu86" / "86_01.amc.gz", skeleton=DATA / "cmu86" / "86.asf")
    warmup()
    if cfgs is None:
        cfgs = {"speeds (defaults)": LOFConfig(), "no speeds": LOFConfig(speed_max=0.0)}
    angles = {c: lof_features(rec, c) for c in cfgs.values()}
    cyc = {c: np.ascontiguousarray(np.tile(a, (n // len(a) + 1, 1))[:n])
           for c, a in ((c, lof_features(r86, c)) for c in cfgs.values())}

    def full_buffer(cfg):  # us/frame with the 75 s buffer full
        det = StreamingLOFSegmenter(cfg, rec.fps)
        g = det.geometry
        full_at = g["capacity"] * g["step"] + g["window"]
        det.learn_many(cyc[cfg][:full_at])
        t = time.perf_counter()
        for i in range(full_at, n, PACKET):
            det.learn_many(cyc[cfg][i:i + PACKET])
        return (time.perf_counter() - t) / (n - full_at) * 1e6

    tasks = {"learn_many(120) from positions, frames/s": lambda c: N / median_time(
                 lambda: stream_many(rec, c), 1),
             "learn_one, angles given, frames/s": lambda c: N / median_time(
                 lambda: stream_one(rec, c, angles[c]), 1),
             "offline, features included, ms": lambda c: 1e3 * median_time(
                 lambda: offline_ours(rec, c), 1),
             "75 s buffer full, us/frame": full_buffer}
    res = {(t, k): [] for t in tasks for k in cfgs}
    for _ in range(runs):
        for t, fn in tasks.items():
            for k, c in cfgs.items():
                res[t, k].append(fn(c))
    print(f"{what} on/off, interleaved, median of {runs} runs ({N} frames; buffer "
          f"full: 86_01 cycled to {n})")
    on_label, off_label = (k.split(" (")[0] for k in cfgs)
    print(f"{'computation':44s} {on_label:>12s} {off_label:>12s} {'ratio':>6s}")
    for t in tasks:
        on, off = (float(np.median(res[t, k])) for k in cfgs)
        print(f"{t:44s} {on:12,.2f} {off:12,.2f} {on / off:6.2f}")


def main():
    import warnings

    if "--steady" in sys.argv[1:]:
        steady_state()
        return
    if "--speed-columns" in sys.argv[1:]:
        speed_columns_cost()
        return
    if "--novelty" in sys.argv[1:]:
        speed_columns_cost(cfgs={"novelty (defaults)": LOFConfig(),
                                 "no novelty": LOFConfig(novelty=0.0)}, what="novelty check")
        return
    if "--root-speeds" in sys.argv[1:]:
        speed_columns_cost(cfgs={"root speeds (defaults)": LOFConfig(),
                                 "no root speeds": LOFConfig(root_speed_max=0.0)},
                           what="root speeds")
        return
    if "--two-stage" in sys.argv[1:]:
        speed_columns_cost(cfgs={"two stages (early 1.2 s)": LOFConfig(early_delay_s=1.2),
                                 "one stage (defaults)": LOFConfig()}, what="two stages")
        return

    warnings.filterwarnings("ignore")
    cfg = LOFConfig()
    rec = recording()
    angles = lof_features(rec, cfg)
    t = time.perf_counter()
    warmup()
    print(f"warmup (compile or load cache): {time.perf_counter() - t:.2f} s")
    offline_ours(rec, cfg)
    offline_sklearn(rec, cfg)
    print(f"{N} frames at {rec.fps:g} Hz, defaults {cfg}\n")
    rows = []
    t_off = median_time(lambda: offline_ours(rec, cfg))
    t_off_sk = median_time(lambda: offline_sklearn(rec, cfg))
    t_feat = median_time(lambda: lof_features(rec, cfg))
    rows.append(("offline, features included", t_off, t_off_sk))
    t_many = median_time(lambda: stream_many(rec, cfg))
    t_sk = median_time(lambda: stream_sklearn(rec, cfg))
    rows.append(("stream learn_many(120), from positions", t_many, t_sk))
    t_one = median_time(lambda: stream_one(rec, cfg))
    rows.append(("stream learn_one, from positions", t_one, t_sk))
    t_one_a = median_time(lambda: stream_one(rec, cfg, angles))
    rows.append(("stream learn_one, angles given", t_one_a, t_sk))
    print(f"{'computation':42s} {'ours':>10s} {'frames/s':>11s} {'sklearn':>10s} "
          f"{'frames/s':>11s} {'speed-up':>8s}")
    for name, ours, sk in rows:
        print(f"{name:42s} {ours * 1e3:8.1f}ms {N / ours:11,.0f} {sk * 1e3:8.1f}ms "
              f"{N / sk:11,.0f} {sk / ours:7.1f}x")
    print(f"\n(the features alone, bone angles and root speeds, for {N} frames: "
          f"{t_feat * 1e3:.1f} ms; targets: offline < 50 ms, learn_many >= 100,000 frames/s)")


if __name__ == "__main__":
    main()
