"""The controller's dashboard server (port 29999) from plain sockets: the project's one dashboard
client, and the one place that asks the PolyScope version and Remote Control.

One line out, one line back, every wait bounded. A session (robot/ur/arm.py) keeps one
``Dashboard`` for its whole life and asks its version and Remote Control through it; ``status``
reads the controller through one of its own (robot/ur/readout.py); a session whose RTDE link is
lost stops the program through fresh connections (``stop_program_until_confirmed``). No ur_rtde
code is involved, so nothing here can reconnect or hang (docs/ur-rtde.md, "Dashboard server").
Standard library only.
"""

from __future__ import annotations

import logging
import socket
import time
from types import TracebackType

log = logging.getLogger(__name__)

DASHBOARD_PORT = 29999
MAX_LINE = 4096
"""Longest answer line read (a loaded program's path is the longest the commands used here get)."""
REMOTE_CONTROL_SINCE = (5, 6)
"""PolyScope 5.6 introduced Local/Remote Control and the dashboard's ``is in remote control``
(ur_rtde 1.6.5 asks it from 5.6 too). A CB3 (PolyScope 3) or an older e-Series has no local mode:
any client may command it (docs/ur-rtde.md, "PolyScope versions")."""
ROBOT_MODEL_SINCE = {3: (3, 12), 5: (5, 6)}
"""The dashboard's ``get robot model``: from PolyScope 3.12 (CB3) and 5.6 (e-Series); an older
controller does not say which arm it drives."""
STOP_DEADLINE_S = 15.0
"""How long a stop through the dashboard is retried after the RTDE link is lost (a controller
that stalled for 8 s still gets its stop once it answers again)."""
STOP_RETRY_S = 0.25


def parse_version(text: str) -> tuple[int, ...] | None:
    """(5, 15, 0, 1234) from the dashboard's 'URSoftware 5.15.0.1234 (Jul 12 2023)' or from
    '5.15.0.1234'; None when no version is found."""
    for word in text.split():
        parts = word.split(".")
        if len(parts) > 1 and all(part.isdigit() for part in parts):
            return tuple(int(part) for part in parts)
    return None


class Dashboard:
    """One connection to the dashboard server; use as a context manager.

    Raises ``OSError`` on a socket failure or a timeout (``timeout_s`` for the connect and for
    every answer) and ``ConnectionError`` (an ``OSError``) when the server sends no banner or
    closes without answering.
    """

    def __init__(self, host: str, timeout_s: float) -> None:
        self._sock = socket.create_connection((host, DASHBOARD_PORT), timeout=timeout_s)
        self._reader = self._sock.makefile("r", encoding="utf-8", errors="replace", newline="\n")
        self._unanswered = 0
        """Requests sent whose answer was never read (an ask interrupted by Ctrl-C)."""
        try:
            if not self._reader.readline(MAX_LINE):
                raise ConnectionError("no banner")
        except BaseException:
            self.close()
            raise

    def __enter__(self) -> Dashboard:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def ask(self, command: str) -> str:
        """Send one command line; its answer line, stripped."""
        # An earlier ask cut short after its request left (Ctrl-C) has an answer on its way:
        # read past it, or every later answer would be the one before it.
        while self._unanswered:
            self._answer(command)
            self._unanswered -= 1
        self._unanswered += 1
        started = time.perf_counter()
        self._sock.sendall(command.encode("ascii") + b"\n")
        answer = self._answer(command)
        self._unanswered -= 1
        log.debug(
            "dashboard %r -> %.60r in %.2f ms",
            command,
            answer,
            (time.perf_counter() - started) * 1000.0,
        )
        return answer

    def _answer(self, command: str) -> str:
        answer = self._reader.readline(MAX_LINE)
        if not answer:
            raise ConnectionError(f"no answer to {command!r}")
        return answer.strip()

    def polyscope_version(self) -> tuple[int, ...] | None:
        """PolyScope's version (major, minor, bugfix, build) from ``PolyscopeVersion``; None
        when the answer holds no version number."""
        return parse_version(self.ask("PolyscopeVersion"))

    def in_remote_control(self, version: tuple[int, ...] | None) -> bool:
        """Whether the pendant is in Remote Control, for a controller of ``version`` (as
        ``polyscope_version`` gives it).

        Only PolyScope 5.6 and later have Local/Remote Control and the dashboard's ``is in remote
        control``: an older controller is always commandable (True, nothing asked), and would
        answer ``Could not understand``, which must not read as "local". An unreadable version
        (None) is asked: a controller without the command then reads as local and is refused,
        the safe side.
        """
        if version is not None and version[:2] < REMOTE_CONTROL_SINCE:
            return True
        return self.ask("is in remote control").lower() == "true"

    def robot_model(self, version: tuple[int, ...] | None) -> str | None:
        """The arm the controller drives as its dashboard names it (``UR5``: e-Series and CB3
        alike), for a controller of ``version``; None where that version cannot say (nothing
        asked) or the answer names no arm (``Could not understand``)."""
        since = None if version is None else ROBOT_MODEL_SINCE.get(version[0])
        if since is None or version is None or version[:2] < since:
            return None
        answer = self.ask("get robot model")
        return answer if answer.upper().startswith("UR") else None

    def close(self) -> None:
        self._reader.close()
        self._sock.close()


def stop_program(host: str, timeout_s: float = 2.0) -> tuple[bool, str]:
    """Stop the running program through a fresh dashboard connection.

    Returns whether the controller confirmed that no program runs (``Stopped``, or
    ``programState`` answering ``STOPPED`` when the stop itself was refused) and its answers;
    raises ``OSError`` as ``Dashboard`` does.
    """
    with Dashboard(host, timeout_s) as dashboard:
        reply = dashboard.ask("stop")
        if reply.lower().startswith("stopped"):
            return True, reply
        state = dashboard.ask("programState")
        return state.upper().startswith("STOPPED"), f"{reply}; programState: {state}"


def stop_program_until_confirmed(host: str) -> None:
    """The last resort once a session's RTDE link is gone: ``stop_program`` on fresh connections
    until the controller confirms or ``STOP_DEADLINE_S`` passes (a stalled controller may answer
    only later). Logged as an error when it could not be confirmed: the arm may still be moving.
    Never raises for the controller's silence."""
    deadline = time.monotonic() + STOP_DEADLINE_S
    attempts = 0
    while True:
        attempts += 1
        try:
            confirmed, reply = stop_program(host)
        except OSError as exc:
            confirmed, reply = False, f"no answer ({exc})"
        if confirmed:
            log.warning("link to %s lost: dashboard stop confirmed (%r)", host, reply)
            return
        if time.monotonic() > deadline:
            log.error(
                "LINK TO %s LOST AND THE STOP COULD NOT BE CONFIRMED after %d attempts in "
                "%.0f s (last answer: %s): the arm may still be moving; use the emergency stop",
                host,
                attempts,
                STOP_DEADLINE_S,
                reply,
            )
            return
        time.sleep(STOP_RETRY_S)
