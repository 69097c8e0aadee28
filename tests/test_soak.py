"""The soak of benchmarks/soak.py, short: about 75 s against one real daemon with senders
that come and go (replays at full speed and real time, raw packets of 1 to 12,000 frames in
float32 and float64, re-announces), slow and vanishing subscribers, control requests and a
SIGKILL + restart. Nothing here depends on how fast the machine is: the daemon must not die
by itself, and every numbered event a subscriber saw live must be in the log as it was seen.
"""

from __future__ import annotations

import pytest

from benchmarks.soak import run_soak


@pytest.mark.timeout(600)
def test_a_short_soak_does_not_kill_the_daemon_nor_lose_a_logged_event(tmp_path, warm_kernels):
    r = run_soak(75.0, tmp_path, seed=3, kill_every=35.0)
    assert r["kills"] >= 1  # the restart path ran
    assert r["deaths"] == [], f"the daemon died by itself: exit {r['deaths']}"
    assert r["load_errors"] == []
    assert r["seen_live"] > 0 and r["missing_from_log"] == 0
    assert r["taken"] > 0
