"""benchmarks/consumer_view.py --source cli: ``streamseg serve``, ``replay`` and ``listen`` as
separate processes on free loopback ports, so two runs go side by side (fixed ports made the
second run's ``serve`` fail to bind)."""

from __future__ import annotations

import sys
import threading
from pathlib import Path
from types import SimpleNamespace

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.mark.timeout(600)
def test_two_cli_runs_side_by_side_each_get_their_own_ports(warm_kernels):
    if str(BENCH) not in sys.path:
        sys.path.insert(0, str(BENCH))
    import consumer_view as cv

    item = next(i for i in cv.labelled(("cmu",)) if i.name == "86_01")
    rec = item.recording.slice(0, int(12 * item.recording.fps))  # its first boundary, 4.6 s
    args = cv.parser().parse_args(["--source", "cli", "--speed", "4"])
    got = [None, None]

    def run(j):
        got[j] = cv.from_cli(SimpleNamespace(recording=rec), args)

    threads = [threading.Thread(target=run, args=(j,)) for j in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(600)
    for events, n in got:
        assert n == rec.n_frames
        final = [e for _, e in events if e.type == "segments" and e.final]
        assert len(final) == 1 and final[0].end == n  # each run saw its whole take
        assert any(e.type == "cut" for _, e in events)
