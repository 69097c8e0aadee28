from __future__ import annotations

from pathlib import Path

import pytest

DATA = Path(__file__).resolve().parents[1] / "data"


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """The repository's bundled real recordings (see data/README.md)."""
    return DATA


@pytest.fixture(autouse=True)
def _private_state_home(tmp_path, monkeypatch):
    """`streamseg serve` keeps its event log under $XDG_STATE_HOME by default: a test's own."""
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "xdg-state"))
