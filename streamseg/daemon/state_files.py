"""The state directory's SQLite files (``events.sqlite``, ``checkpoints.sqlite``): where they
live, how they are opened, what is done with a damaged one, and the error reading one gives."""

from __future__ import annotations

import os
import sqlite3
import time
from pathlib import Path


class LogReadError(RuntimeError):
    """The event log could not be read (a damaged file); the message names the file."""


def default_state_dir() -> Path:
    """``$XDG_STATE_HOME/streamseg``, else ``~/.local/state/streamseg``."""
    base = os.environ.get("XDG_STATE_HOME") or os.path.join(
        os.path.expanduser("~"), ".local", "state"
    )
    return Path(base) / "streamseg"


def connect(path: Path, auto_vacuum: bool = False) -> sqlite3.Connection:
    """A connection in WAL mode (readers never block the writer), autocommit off;
    ``auto_vacuum``: incremental (takes effect on a new file only)."""
    con = sqlite3.connect(str(path), timeout=30, check_same_thread=False, isolation_level=None)
    if auto_vacuum:  # before WAL mode writes the file's first page
        con.execute("PRAGMA auto_vacuum=INCREMENTAL")
    con.execute("PRAGMA journal_mode=WAL")
    # NORMAL in WAL: a commit survives a crash of the process (kill -9); only a power loss
    # can take the last commits, and never corrupts the file
    con.execute("PRAGMA synchronous=NORMAL")
    return con


def move_aside(path: Path, name: str) -> Path:
    """Rename the SQLite file ``path`` (and its ``-wal``, ``-shm``) to ``<name>.corrupt-<time>
    .sqlite`` beside it; returns the new path."""
    stamp, k = int(time.time()), 0
    while (
        aside := path.with_name(f"{name}.corrupt-{stamp}{f'-{k}' if k else ''}.sqlite")
    ).exists():
        k += 1  # never over an earlier one
    for suffix in ("", "-wal", "-shm"):
        src = Path(str(path) + suffix)
        if src.exists():
            src.rename(str(aside) + suffix)
    return aside
