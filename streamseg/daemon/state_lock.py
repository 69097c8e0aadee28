"""One daemon per state directory: an exclusive ``flock`` on ``<state_dir>/lock``.

Two daemons on one state directory would both restore its checkpoints (the second resumes
streams the first is serving), number the same streams' events in one log, and each delete
the other's checkpoints when it closes those streams. The OS drops a ``flock`` when its
process dies, kill -9 included, so a crash never leaves a stale lock to clean up by hand.
"""

from __future__ import annotations

import os
from pathlib import Path

from streamseg.exceptions import ParameterError


class StateDirInUse(ParameterError):
    """Another live process holds the state directory's lock."""


def lock_state_dir(state_dir) -> int | None:
    """Take ``<state_dir>/lock`` (created with the folder); returns its file descriptor, to
    give to :func:`unlock`. None where ``fcntl`` does not exist (not POSIX): no lock.

    Raises
    ------
    StateDirInUse
        When another process (or another daemon of this one) holds it.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - POSIX only
        return None
    d = Path(state_dir).expanduser()
    d.mkdir(parents=True, exist_ok=True)
    fd = os.open(d / "lock", os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = os.read(fd, 32).decode("ascii", "replace").strip() or "?"
        os.close(fd)
        raise StateDirInUse(
            f"--state-dir {state_dir} is in use by another daemon (pid "
            f"{holder}): stop it, or give this one its own, e.g. --state-dir "
            f"{Path(state_dir).expanduser()}-2 (or --state-dir none: no "
            "event log, no checkpoints)"
        ) from None
    os.ftruncate(fd, 0)
    os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)  # for the message above, informative only
    return fd


def unlock(fd: int | None) -> None:
    """Release a lock taken by :func:`lock_state_dir` (closing the descriptor drops it)."""
    if fd is not None:
        os.close(fd)
