from __future__ import annotations

from pathlib import Path

import pytest

DATA = Path(__file__).resolve().parents[1] / "data"


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """The repository's bundled real recordings (see data/README.md)."""
    return DATA


@pytest.fixture(scope="session")
def rec(data_dir):
    """CMU 86_01 (walk, jump, punch, kick; 4579 frames at 120 Hz), read once per session."""
    from streamseg.io import read

    return read(data_dir / "cmu86" / "86_01.amc.gz", skeleton=data_dir / "cmu86" / "86.asf")


@pytest.fixture(scope="session")
def bd_squats(data_dir):
    """(recording, true repetitions): four real HDM05 squat clips of actor bd concatenated
    (takes 001-004; the joins are the true boundaries, see data/README.md)."""
    import numpy as np

    from streamseg.io import read
    from streamseg.recording import Recording

    asf = data_dir / "hdm05_reps" / "asf" / "HDM_bd.asf"
    recs = [
        read(
            data_dir / "hdm05_reps" / "squat1Reps" / f"HDM_bd_squat1Reps_{t}_120.amc.gz",
            skeleton=asf,
        )
        for t in ("001", "002", "003", "004")
    ]
    pos = np.concatenate([r.positions for r in recs])
    ends = np.cumsum([r.n_frames for r in recs])
    truth = list(zip([0, *ends[:-1].tolist()], ends.tolist()))
    return Recording(120.0, recs[0].skeleton, pos, source="4 concatenated squats"), truth


@pytest.fixture(scope="session")
def warm_kernels() -> None:
    """Every numba kernel compiled (or loaded from the cache) once per session, so that no
    test's waits include compilation: a daemon started after this is ready at once."""
    from streamseg.daemon.algorithms import Algorithms

    Algorithms(repetitions=True).warmup()


def wait_ready(daemon, thread) -> None:
    """Wait for ``daemon.ready`` (set once its kernels are warm) however long compilation
    takes, failing at once if the daemon's thread died instead."""
    from tests.waiting import wait_until

    wait_until(
        lambda: daemon.ready.is_set() or not thread.is_alive(),
        "the daemon ready",
        timeout=600,  # compilation on a loaded machine: a bound, far above its usual seconds
    )
    assert daemon.ready.is_set(), "the daemon thread ended before it was ready"


@pytest.fixture(autouse=True)
def _private_state_home(tmp_path, monkeypatch):
    """`streamseg serve` keeps its event log under $XDG_STATE_HOME by default: a test's own."""
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "xdg-state"))


@pytest.fixture
def start_daemon(warm_kernels):
    """``start(algorithms=None, **DaemonConfig overrides) -> (daemon, endpoints)``: a daemon on
    free loopback ports in a thread, ready (kernels warm); every one started is stopped and
    joined at the end of the test."""
    import threading

    from streamseg.config import DaemonConfig
    from streamseg.daemon import Daemon

    running = []

    def start(algorithms=None, **overrides):
        loop = "tcp://127.0.0.1:0"
        cfg = dict(ingest=loop, publish=loop, control=loop, relabel_interval=0, heartbeat=0.2)
        cfg.update(overrides)
        d = Daemon(DaemonConfig(**cfg), algorithms)
        ep = d.bind()
        t = threading.Thread(target=d.run, daemon=True, name="streamseg-daemon-under-test")
        t.start()
        wait_ready(d, t)
        running.append((d, t))
        return d, ep

    yield start
    for d, t in running:
        d.stop()
        t.join(10)
        assert not t.is_alive()
