"""One session per robot: an advisory lock per controller host, taken before anything connects.

A second ``pick`` or ``run`` on a robot that a session already drives would otherwise connect,
stop the first session's control program and fail at ur_rtde's register claim with a message
about fieldbus adapters. The lock (``flock``, released by the kernel when the holder closes it
or dies, so a killed process leaves no stale lock) lives in one folder for every user of this
machine; the file names its holder (pid, command line, since when) for the refusal's message.
Read-only commands (``status``, ``plan``) take no lock: they leave the controller as found;
``status`` asks who holds it (``holder``), since a pick cannot start while someone does.
"""

from __future__ import annotations

import fcntl
import json
import os
import re
import sys
import tempfile
from datetime import datetime, timezone
from pathlib import Path

from handeye_pick.errors import SafetyRefusal

LOCK_FOLDER = Path(tempfile.gettempdir()) / "handeye-pick-cells"
"""Where the locks live: shared by every user of the machine (sticky, world-writable)."""


class CellInUse(SafetyRefusal):
    """Another process drives this robot; nothing was sent (exit 3)."""


class CellLock:
    """The lock of the robot at ``host``, held from ``acquire`` until ``release``."""

    def __init__(self, host: str) -> None:
        self.host = host
        self.path = LOCK_FOLDER / f"{re.sub(r'[^A-Za-z0-9_.-]', '_', host)}.lock"
        self._fd: int | None = None

    def acquire(self) -> None:
        """Take the lock, or raise ``CellInUse`` naming its holder."""
        if self._fd is not None:
            return
        _make_folder()
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(fd)
            os.close(fd)
            raise CellInUse(
                f"cell {self.host} is in use by {holder}: stop that session (or let it finish) "
                "before starting another on this robot; nothing was sent"
            ) from None
        except OSError:
            os.close(fd)
            raise
        owner = {
            "pid": os.getpid(),
            "command": _command_line(),
            "since": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        }
        os.ftruncate(fd, 0)
        os.pwrite(fd, json.dumps(owner).encode(), 0)
        self._fd = fd

    def holder(self) -> str | None:
        """Who holds the lock now, as ``CellInUse`` names it, or None when it is free (for
        ``status``: a shared lock for an instant, nothing written)."""
        try:
            fd = os.open(self.path, os.O_RDONLY)
        except OSError:  # no lock file (never taken here), or one this user cannot read
            return None
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return _holder(fd)
        finally:
            os.close(fd)  # also releases the shared lock
        return None

    def release(self) -> None:
        """Release the lock; safe to call twice."""
        if self._fd is not None:
            os.close(self._fd)  # closing the descriptor releases the flock
            self._fd = None


def _command_line() -> str:
    """This process's command line as a person would type it (``handeye-pick run ...``)."""
    name = "python -c" if sys.argv[0] == "-c" else Path(sys.argv[0]).name
    return " ".join([name, *sys.argv[1:]])


def _make_folder() -> None:
    try:
        LOCK_FOLDER.mkdir(mode=0o1777, exist_ok=True)
        os.chmod(LOCK_FOLDER, 0o1777)  # mkdir's mode is masked by the umask
    except PermissionError:
        pass  # made by another user, who set its mode


def _holder(fd: int) -> str:
    """Who holds the lock, as the file says (it may be mid-write: then just "another process")."""
    try:
        owner = json.loads(os.pread(fd, 4096, 0) or b"{}")
        return f"process {owner['pid']} ({owner['command']}) since {owner['since']}"
    except (ValueError, KeyError, TypeError, OSError):
        return "another process"
