from __future__ import annotations

from pathlib import Path

import pytest

DATA = Path(__file__).resolve().parents[1] / "data"


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """The repository's bundled real recordings (see data/README.md)."""
    return DATA


@pytest.fixture(scope="session")
def warm_kernels() -> None:
    """Every numba kernel compiled (or loaded from the cache) once per session, so that no
    test's waits include compilation: a daemon started after this is ready at once."""
    from streamseg.daemon.pipeline import Algorithms

    Algorithms(repetitions=True).warmup()


def wait_ready(daemon, thread) -> None:
    """Wait for ``daemon.ready`` (set once its kernels are warm) however long compilation
    takes, failing at once if the daemon's thread died instead."""
    while not daemon.ready.wait(1.0):
        assert thread.is_alive(), "the daemon thread ended before it was ready"


@pytest.fixture(autouse=True)
def _private_state_home(tmp_path, monkeypatch):
    """`streamseg serve` keeps its event log under $XDG_STATE_HOME by default: a test's own."""
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "xdg-state"))
