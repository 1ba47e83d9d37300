"""The ur_rtde child when its parent is SIGKILLed in the middle of a request (found by
benchmarks/chaos.py): it must leave at once, as at end of file, not through an exception.

An exception (the reply's send fails: the parent's end is closed) exits through ur_rtde's
destructors, 0.5 s of sleep each with the RTDE connection still open, so a supervisor that
restarts ``run`` at once met the input registers still claimed and the restart failed with the
message about fieldbus adapters. Here the test plays the parent: it sends a request and closes
its end before the reply, and the child's exit status and output say how it left.
"""

from __future__ import annotations

import socket
import subprocess
import sys
from collections.abc import Callable
from multiprocessing.connection import Connection

from handeye_pick.robot.ur.child import WORKER_SCRIPT
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
