"""The ur_rtde child process of one session (robot/ur/worker.py) and the pipe to it.

The parent never loads ur_rtde: after a lost link ur_rtde 1.6.5 reconnects by itself, loops and
can segfault its process (docs/ur-rtde.md, "What makes the client throw or hang"), which here
can only end the child. ``Child`` spawns it, waits for its hello, sends one request at a time and
waits, bounded, for its answer. A lost link, a dead child or a silent one ends the session
(``dead_reason``); it is never restarted.
"""

from __future__ import annotations

import contextlib
import logging
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from multiprocessing.connection import Connection
from pathlib import Path
from typing import IO

from handeye_pick.errors import RobotConnectionError, RobotError
from handeye_pick.robot.ur.advice import call_error, connect_error
from handeye_pick.robot.ur.worker import Failure

log = logging.getLogger(__name__)

WORKER_SCRIPT = Path(__file__).with_name("worker.py")
HELD_SIGNALS = (signal.SIGINT, signal.SIGTERM)
CLOSE_GRACE_S = 3.0
"""How long a child told to close gets to leave by itself before it is killed."""


@contextlib.contextmanager
def _ctrl_c_held() -> Iterator[None]:
    """Hold Ctrl-C (and SIGTERM) while one message crosses the pipe to the ur_rtde process.

    A KeyboardInterrupt (or ``Terminated``) between the bytes of a message would desynchronise
    the pipe, and the stopL that the signal is about to send would be lost. A held signal is
    delivered as soon as the message is through (a few microseconds). Only the main thread
    receives signals.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []
    previous = {
        signum: signal.signal(signum, lambda received, _frame: held.append(received))
        for signum in HELD_SIGNALS
    }
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        for received in held:
            handler = previous[signal.Signals(received)]
            if callable(handler):
                handler(received, None)
            elif handler == signal.SIG_DFL and received == signal.SIGTERM:
                signal.raise_signal(received)  # no handler of ours: die as SIGTERM would have


def _log_lines(stream: IO[bytes] | None, host: str) -> None:
    """ur_rtde prints to stdout/stderr; keep that off our stdout (--json) and in the debug log."""
    if stream is None:
        return
    # Closed at the end of the child's output: an ended session may stay referenced (a halted
    # cell's traceback, say) until the garbage collector runs, and each one kept a pipe open.
    with stream:
        for raw in stream:
            log.debug("ur_rtde %s: %s", host, raw.decode(errors="replace").rstrip())


class Child:
    """The ur_rtde process connected to ``host``; the constructor returns once it said hello.

    ``watchdog_s`` and ``with_io`` are the worker's (robot/ur/worker.py). ``connect_timeout_s``
    bounds the connection, ``call_timeout_s`` every later call unless the call says otherwise.
    Raises what ``advice.connect_error`` makes of a refused connection, or
    ``RobotConnectionError``.
    """

    def __init__(
        self,
        host: str,
        *,
        with_io: bool,
        watchdog_s: float,
        connect_timeout_s: float,
        call_timeout_s: float,
    ) -> None:
        self.host = host
        self.dead_reason: str | None = None
        """Why the session is over, or None while it lives."""
        self._call_timeout_s = call_timeout_s
        self._pending_reply = False
        # One request and its answer at a time: the line's I/O thread (handeye_pick.line.io)
        # shares the pipe with the thread that runs the cell.
        self._call_lock = threading.Lock()
        parent_socket, child_socket = socket.socketpair()
        # A plain subprocess, not multiprocessing: no re-import of the caller's __main__, and
        # its own session, so a Ctrl-C at the terminal reaches only this process, which then
        # still has a working child to send stopL through.
        self._process = subprocess.Popen(
            [sys.executable, str(WORKER_SCRIPT), str(child_socket.fileno()), host, str(watchdog_s)]
            + (["--io"] if with_io else []),
            pass_fds=(child_socket.fileno(),),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        child_socket.close()
        self._conn = Connection(parent_socket.detach())
        threading.Thread(
            target=_log_lines, args=(self._process.stdout, host), name="ur_rtde output", daemon=True
        ).start()
        log.debug("connecting to %s (ur_rtde in child pid %s)", host, self._process.pid)
        self._hello(connect_timeout_s)

    def _hello(self, timeout_s: float) -> None:
        try:
            kind, value = self._receive("connect", timeout_s)
        except BaseException:
            self.end()
            raise
        if kind == "hello":
            return
        self.end()
        if kind == "failure" and isinstance(value, dict):
            raise connect_error(self.host, Failure(**value))
        raise RobotConnectionError(f"connect to {self.host}: unexpected first message {value!r}")

    def require_alive(self, operation: str) -> None:
        """``RobotConnectionError`` for ``operation`` once the session is over."""
        if self.dead_reason is not None:
            raise RobotConnectionError(
                f"{operation} on {self.host}: the session is over ({self.dead_reason}); "
                "start a new one"
            )

    def call(self, operation: str, *args: object, timeout_s: float | None = None) -> object:
        """One request to the child; its result, or a typed error. Ends the session on a lost
        link, a dead child or no answer within ``timeout_s`` (default ``call_timeout_s``).
        Safe from any thread: calls are served one at a time."""
        with self._call_lock:
            return self._call(operation, args, timeout_s)

    def _call(self, operation: str, args: tuple[object, ...], timeout_s: float | None) -> object:
        timeout_s = self._call_timeout_s if timeout_s is None else timeout_s
        self.require_alive(operation)
        if self._pending_reply:  # a call was interrupted by Ctrl-C: drop its late answer first
            self._receive(operation, timeout_s)
        try:
            with _ctrl_c_held():
                self._conn.send((operation, args))
                # Set inside the hold: a Ctrl-C held during the send is raised as the hold ends,
                # and the next call must still drain this request's answer.
                self._pending_reply = True
        except OSError as exc:
            self.dead_reason = f"the ur_rtde process is gone ({exc})"
            raise RobotConnectionError(f"{operation} on {self.host}: {self.dead_reason}") from None
        started = time.perf_counter()
        kind, value = self._receive(operation, timeout_s)
        if operation != "sample":  # cached RTDE state polled during moves: no controller traffic
            log.debug(
                "%s%s -> %s %.60r in %.2f ms",
                operation,
                tuple(args),
                kind,
                value,
                (time.perf_counter() - started) * 1000.0,
            )
        if kind == "failure" and isinstance(value, dict):
            failure = Failure(**value)
            error = call_error(self.host, failure)
            if isinstance(error, RobotConnectionError):  # the receive stream is stale or gone
                self.end(failure.message)
            raise error
        if kind != "ok":
            raise RobotConnectionError(f"{operation} on {self.host}: unexpected reply {value!r}")
        return value

    def _receive(self, operation: str, timeout_s: float) -> tuple[str, object]:
        """Wait for one ``(kind, value)`` message from the child, bounded; a silent or dead
        child ends the session."""
        deadline = time.monotonic() + timeout_s
        while not self._conn.poll(0.05):
            if self._process.poll() is not None:
                reason = f"the ur_rtde process died (exit status {self._process.returncode})"
                break
            if time.monotonic() > deadline:
                reason = f"no answer to {operation} within {timeout_s} s"
                break
        else:
            try:
                with _ctrl_c_held():
                    message = self._conn.recv()
                    # Cleared inside the hold, for the same reason: a Ctrl-C raised as the hold
                    # ends must not leave the next call waiting for an answer already read.
                    self._pending_reply = False
            except (EOFError, OSError):
                reason = "the ur_rtde process closed its pipe (it probably crashed)"
            else:
                if isinstance(message, tuple) and len(message) == 2:
                    return str(message[0]), message[1]
                reason = f"unexpected message from the ur_rtde process: {message!r}"
        self.end(reason)
        raise RobotConnectionError(f"{operation} on {self.host}: {self.dead_reason}")

    def end(self, reason: str = "the session was closed", grace_s: float = 0.0) -> None:
        """End the session: keep the first ``reason``, end the child (given ``grace_s`` to leave
        by itself) and close the pipe. Safe to call again."""
        if self.dead_reason is None:
            self.dead_reason = reason
        try:
            self._process.wait(timeout=grace_s)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait(timeout=3.0)
        self._conn.close()

    def close(self) -> None:
        """Ask a live child to disconnect every interface and leave, then end it."""
        if self._process.poll() is not None or self.dead_reason is not None:
            self.end()
            return
        try:
            # What became of the session's control script (worker.py ``_end_program``): for the
            # debug log; a script left playing is stopped by its watchdog either way.
            log.debug("closing the ur_rtde session on %s: control script %s", self.host,
                      self.call("close"))
        except RobotError as exc:
            log.warning("closing the ur_rtde session on %s: %s", self.host, exc)
        self.end(grace_s=CLOSE_GRACE_S)
