"""Parse + forward-kinematics throughput: AMC text versus streamseg's native .npz.

Usage: python benchmarks/io_speed.py [--runs 7]

Prints, per input, the median wall time of several full reads (parse and pose, or load) and
frames per second, and the .npz speed-up over the AMC it was written from, measured in the
same run. Target (issue 2): the 4579-frame CMU 86_01 AMC in under 0.25 s; .npz >= 50x faster.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from streamseg.io import read, write_npz

DATA = Path(__file__).resolve().parents[1] / "data"


def median_time(fn, runs: int) -> float:
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7)
    args = ap.parse_args()
    cases = [
        ("CMU 86_01 (.amc.gz)", DATA / "cmu86/86_01.amc.gz", DATA / "cmu86/86.asf"),
        ("CMU 14_14 (.amc.gz)", DATA / "cmu_exercise/14_14.amc.gz", DATA / "cmu86/86.asf"),
    ]
    print(f"{'input':<26}{'frames':>8}{'median s':>11}{'frames/s':>12}{'vs AMC':>9}")
    with tempfile.TemporaryDirectory() as tmp:
        for name, path, asf in cases:
            rec = read(path, skeleton=asf)
            t_amc = median_time(lambda p=path, s=asf: read(p, skeleton=s), args.runs)
            npz = Path(tmp) / (path.name.split(".")[0] + ".npz")
            write_npz(npz, rec)
            t_npz = median_time(lambda f=npz: read(f), args.runs)
            n = rec.n_frames
            print(f"{name:<26}{n:>8}{t_amc:>11.4f}{n / t_amc:>12,.0f}{'1.0x':>9}")
            label = name.replace(".amc.gz", ".npz")
            print(f"{label:<26}{n:>8}{t_npz:>11.4f}{n / t_npz:>12,.0f}{t_amc / t_npz:>8.0f}x")


if __name__ == "__main__":
    main()
