"""The ur_rtde child's end, as benchmarks/chaos.py found it wanting: when its parent is SIGKILLed
in the middle of a request it must leave at once, as at end of file, not through an exception;
and an ended child leaves no pipe open in the parent.

An exception (the reply's send fails: the parent's end is closed) exits through ur_rtde's
destructors, 0.5 s of sleep each with the RTDE connection still open, so a supervisor that
restarts ``run`` at once met the input registers still claimed and the restart failed with the
message about fieldbus adapters. In the first test the test plays the parent: it sends a
request and closes its end before the reply, and the child's exit status and output say how it
left.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from multiprocessing.connection import Connection
from pathlib import Path

from handeye_pick.robot.ur.child import WORKER_SCRIPT, Child
from mocks.ur_controller import SimulatedController
from tests.conftest import TEST_WATCHDOG_S

SimFactory = Callable[..., SimulatedController]


def test_a_child_whose_parent_dies_mid_request_exits_at_once(sim_controller: SimFactory) -> None:
    ctl = sim_controller(instant=True)
    parent_socket, child_socket = socket.socketpair()
    worker = subprocess.Popen(
        [sys.executable, str(WORKER_SCRIPT), str(child_socket.fileno()), ctl.host,
         str(TEST_WATCHDOG_S)],
        pass_fds=(child_socket.fileno(),),
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    child_socket.close()
    parent = Connection(parent_socket.detach())
    try:
        assert parent.poll(60), "the child never said hello"
        kind, _ = parent.recv()
        assert kind == "hello"
        # The request stays readable after the parent's end is closed; its reply cannot go out.
        parent.send(("sample", ()))
        parent.close()
        output, _ = worker.communicate(timeout=60)
    finally:
        if worker.poll() is None:
            worker.kill()
            worker.wait()
    assert "Traceback" not in output, output
    assert worker.returncode == 0, output


def _pipes() -> int:
    """Pipes this process holds open."""
    folder = Path("/proc/self/fd")
    return sum(1 for fd in folder.iterdir() if _target(fd).startswith("pipe:"))


def _target(fd: Path) -> str:
    try:
        return os.readlink(fd)
    except OSError:  # the descriptor listing the folder itself, gone by now
        return ""


def test_an_ended_session_keeps_no_pipe_open_while_it_is_still_referenced(
    sim_controller: SimFactory,
) -> None:
    # Found by benchmarks/chaos.py: run's descriptors grew with every dropped link, one pipe per
    # ended ur_rtde child, until the garbage collector freed the session objects.
    ctl = sim_controller(instant=True)
    before = _pipes()
    child = Child(ctl.host, with_io=False, watchdog_s=TEST_WATCHDOG_S, connect_timeout_s=60.0,
                  call_timeout_s=10.0)
    child.close()
    deadline = time.monotonic() + 10.0  # the output thread sees the end of the child's output
    while _pipes() != before and time.monotonic() < deadline:
        time.sleep(0.02)
    assert _pipes() == before, f"{_pipes() - before} pipes left open by {child.dead_reason!r}"
