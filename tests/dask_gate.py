"""A relabel that waits at a gate (a file) so a test can act while a job is running.

Importable by Dask worker processes (``tests`` is a package; the test puts the repository
on their PYTHONPATH). Short windows (the daemon's and the workers' warm-ups) pass at once.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from tests.waiting import wait_until

GATED_ROWS = 1000  # windows at least this long wait for the gate


def gated_relabel(gate_dir, features, *, start_frame, fps, config, previous):
    """:func:`streamseg.offline.relabel_window`, after ``gate_dir/release`` exists; writes
    ``gate_dir/started-<pid>-<n>`` first so the test knows which process runs it."""
    from streamseg.offline import relabel_window

    if features.shape[0] >= GATED_ROWS:
        gate = Path(gate_dir)
        n = len(list(gate.glob(f"started-{os.getpid()}-*")))
        (gate / f"started-{os.getpid()}-{n}").touch()
        deadline = time.monotonic() + 120
        while not (gate / "release").exists() and time.monotonic() < deadline:
            time.sleep(0.01)  # the job itself waits: this is the job being slow
    return relabel_window(
        features, start_frame=start_frame, fps=fps, config=config, previous=previous
    )


def started(gate_dir) -> list[int]:
    """Pids that have started a gated job, in the order they did."""
    files = sorted(Path(gate_dir).glob("started-*"), key=lambda p: p.stat().st_mtime_ns)
    return [int(p.name.split("-")[1]) for p in files]


def wait_started(gate_dir, count: int, timeout: float = 120.0) -> list[int]:
    """Wait until ``count`` gated jobs have started; their pids."""
    return wait_until(
        lambda: len(pids := started(gate_dir)) >= count and pids,
        f"{count} gated relabel(s) started",
        timeout,
    )
