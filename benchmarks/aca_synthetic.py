"""Section 5.1 of Zhou et al. (2008): ACA on synthetic 1-D sequences.

4 classes, segment lengths 10-15, values uniform integers 1..20, a noise frame inserted after
each frame with probability p_noise, equality kernel (sigma -> 0), 10 random restarts, 10
sequences of 20 segments per setting; mean and min Hungarian-matched frame accuracy and the
mean time per sequence. Every fit goes through the command line path for plain matrices
(``streamseg segment seq.npy --method aca ...``), as a user would run it.

The authors' code reaches a mean accuracy of 0.99 at p_noise = 0 on 20-segment sequences.
Parameters are the generator's: lengths 10..15. Noise frames make segments longer (a mean of
12.5 * (1 + p)), so a second row per p_noise widens max_len to round(15 * (1 + p)) (the
generator's longest segment plus the expected noise) to show what that costs or buys.

Each setting runs twice: given the true K = 4, and with K found (``--clusters`` omitted: the
piece silhouette of ``streamseg.offline.model_selection`` over K = 2..8); "K found" counts the
sequences per K found.

Run: ``.venv/bin/python benchmarks/aca_synthetic.py [--sequences 10]``
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import tempfile
import time
from pathlib import Path

import _common  # noqa: F401  (the package beside us when run from a clone)
import numpy as np

from streamseg.cli import main as cli_main
from streamseg.evaluation.metrics import matched_frame_accuracy
from streamseg.evaluation.synthetic import synthetic_sequence


def run_cli(path, min_len, max_len, seed, k=4):
    argv = [
        "segment",
        str(path),
        "--method",
        "aca",
        "--fps",
        "1",
        "--flat",
        "--kernel",
        "equality",
        "--min-len",
        str(min_len),
        "--max-len",
        str(max_len),
        "--restarts",
        "10",
        "--seed",
        str(seed),
        "--json",
    ] + (["--clusters", str(k)] if k else [])
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = cli_main(argv)
    if code != 0:
        raise RuntimeError(f"streamseg {' '.join(argv)} exited with {code}")
    return json.loads(out.getvalue())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sequences", type=int, default=10)
    ap.add_argument("--segments", type=int, default=20)
    args = ap.parse_args()
    print(
        f"{'p_noise':>7} {'min_len':>7} {'max_len':>7} {'K':>7} {'mean acc':>9} "
        f"{'min acc':>8} {'K found':>22} {'frames':>7} {'s/seq':>7}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        for p in (0.0, 0.1, 0.2, 0.3):
            for max_len, k in [
                (m, k) for m in sorted({15, round(15 * (1 + p))}) for k in (4, None)
            ]:
                accs, times, frames, found = [], [], [], []
                for i in range(args.sequences):
                    rng = np.random.default_rng(1000 * int(p * 10) + i)
                    x, truth = synthetic_sequence(args.segments, p, rng)
                    path = Path(tmp) / f"seq_{p}_{i}.npy"
                    np.save(path, x)
                    t0 = time.perf_counter()
                    res = run_cli(path, 10, max_len, seed=i, k=k)
                    times.append(time.perf_counter() - t0)
                    labels = np.empty(len(x), dtype=np.int64)
                    for s in res["segments"]:
                        labels[s["start"] : s["end"]] = s["label"]
                    accs.append(matched_frame_accuracy(labels, truth)[0])
                    frames.append(len(x))
                    found.append(res["n_clusters"])
                counts = "-" if k else " ".join(f"{v}:{found.count(v)}" for v in sorted(set(found)))
                print(
                    f"{p:7.1f} {10:7d} {max_len:7d} {k or 'found':>7} {np.mean(accs):9.3f} "
                    f"{np.min(accs):8.3f} {counts:>22} {np.mean(frames):7.0f} "
                    f"{np.mean(times):7.3f}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
