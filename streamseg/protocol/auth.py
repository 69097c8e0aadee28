"""The control token: what proves, without CURVE, that a client runs as the daemon's user.

Without CURVE every local user can reach a loopback socket, so the daemon writes a random
token to a file only its user can read (mode 0600 in a 0700 directory, as Jupyter does with
its connection files): ``$XDG_RUNTIME_DIR/streamseg/control.token`` when that runtime
directory is set, else ``$XDG_STATE_HOME/streamseg/control.token`` (``~/.local/state``).
State-changing control requests (``shutdown``, ``checkpoint``) carry it as ``auth``, and so
may an ``announce`` or ``end`` of a stream another connection announced; our clients read
it by themselves (``STREAMSEG_TOKEN`` overrides the file, e.g. for a client on another
machine of a trusted ``--insecure`` network). One token per user, kept across restarts:
delete the file to change it (daemons running keep theirs until restarted).
"""

from __future__ import annotations

import hmac
import os
import secrets
from pathlib import Path

FILE = "control.token"


def token_path() -> Path:
    """The token file of the user running this process."""
    run = os.environ.get("XDG_RUNTIME_DIR")
    base = (
        Path(run)
        if run
        else Path(os.environ.get("XDG_STATE_HOME") or Path.home() / ".local" / "state")
    )
    return base / "streamseg" / FILE


def read_token() -> str | None:
    """The token a client sends: ``STREAMSEG_TOKEN``, else the file's (None: unreadable)."""
    env = os.environ.get("STREAMSEG_TOKEN")
    if env:
        return env
    try:
        return token_path().read_text().strip() or None
    except (OSError, UnicodeDecodeError):
        return None


def _private(path: Path) -> bool:
    st = path.stat()
    return st.st_uid == os.geteuid() and not st.st_mode & 0o077


def daemon_token() -> tuple[str, Path]:
    """The daemon's token and its file: the existing one when it is private (ours, 0600),
    else a new one (written to a temporary file, then linked into place: a concurrent start
    reads the same token, never a half-written one). Raises OSError when it cannot write."""
    path = token_path()
    path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
    if path.parent.stat().st_uid == os.geteuid():
        path.parent.chmod(0o700)
    for _ in range(3):
        try:
            if _private(path):
                token = path.read_text().strip()
                if len(token) >= 32:
                    return token, path
            path.unlink()  # readable by others, not ours, or damaged: replaced
        except FileNotFoundError:
            pass
        tmp = path.with_name(f".{FILE}.{os.getpid()}.{secrets.token_hex(4)}")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        token = secrets.token_hex(32)
        with os.fdopen(fd, "w") as fh:
            fh.write(token + "\n")
        try:
            os.link(tmp, path)
            return token, path
        except FileExistsError:  # another daemon of this user was first: take its token
            continue
        finally:
            tmp.unlink()
    raise OSError(f"{path}: could not write the control token")


def matches(given, token: str | None) -> bool:
    """Whether a request's ``auth`` is the daemon's token (constant time)."""
    return (
        token is not None
        and isinstance(given, str)
        and hmac.compare_digest(given.encode(), token.encode())
    )
