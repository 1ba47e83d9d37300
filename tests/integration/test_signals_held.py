"""Every signal the session handles is held while a message crosses the pipe to the ur_rtde
process (issue 21): SIGINT (Ctrl-C) and SIGTERM (a supervisor; the CLI turns it into
``Terminated``, handled like Ctrl-C).

The worst moment for a signal is right after a request or an answer has crossed the pipe and
before the session has noted it: raised there, the next call reads the previous call's answer
(after a request), or waits for an answer already read (after an answer). The signal is sent
from a profiler hook on the return of the pipe's ``send`` or ``recv`` (the stdlib
``multiprocessing.connection.Connection``), in the main thread, so it lands exactly there.
Held, it is delivered as the message's hold ends, and every later call still gets its own
answer. The Cell, its arm and the simulated controller are the real ones.
"""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from multiprocessing.connection import Connection
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np
import pytest

from handeye_pick import Cell
from handeye_pick.errors import Terminated
from handeye_pick.geometry import invert, ur_pose_to_matrix
from mocks.ur_controller import SimulatedController
from tests.integration.test_pick_cli import TCP_OFFSET, motion_commands, write_config

SimFactory = Callable[..., SimulatedController]

# What each signal raises in the session: Ctrl-C Python's own KeyboardInterrupt, SIGTERM the
# CLI's Terminated (handeye_pick.cli installs a handler that raises it).
RAISES: dict[signal.Signals, type[KeyboardInterrupt]] = {
    signal.SIGINT: KeyboardInterrupt,
    signal.SIGTERM: Terminated,
}


def _raise_terminated(signum: int, frame: FrameType | None) -> None:
    raise Terminated


@contextmanager
def _signal_after(method: str, signum: signal.Signals) -> Iterator[list[str]]:
    """Send ``signum`` to this process once, right as the next pipe ``method`` (``send`` or
    ``recv``) of this thread returns; the list says whether it was sent."""
    code = getattr(Connection, method).__code__
    sent: list[str] = []

    def hook(frame: FrameType, event: str, arg: Any) -> None:
        if event == "return" and frame.f_code is code and not sent:
            sent.append(method)
            os.kill(os.getpid(), signum)

    sys.setprofile(hook)
    try:
        yield sent
    finally:
        sys.setprofile(None)


@pytest.fixture
def terminated_on_sigterm() -> Iterator[None]:
    """SIGTERM handled as the CLI handles it, for the test's duration."""
    previous = signal.signal(signal.SIGTERM, _raise_terminated)
    yield
    signal.signal(signal.SIGTERM, previous)


@pytest.mark.parametrize("method", ["send", "recv"])
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_a_signal_right_after_a_message_keeps_every_answer_with_its_call(
    sim_controller: SimFactory,
    tmp_path: Path,
    terminated_on_sigterm: None,
    signum: signal.Signals,
    method: str,
) -> None:
    """Guards ``HELD_SIGNALS = (signal.SIGINT, signal.SIGTERM)`` and the holds around the
    pipe's send and recv in Child.call / _receive (robot/ur/child.py): a SIGTERM (or
    Ctrl-C) that lands right after the TCP offset request (or its answer) crossed the pipe
    interrupts that call only; the flange pose, the TCP offset, the readiness and a move that
    follow all get their own answers. Not held, the next call read the TCP offset's answer as a
    sample (after a send), or waited 6 s for an answer already read (after a recv)."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    target = list(ctl.snapshot().tcp_pose)
    target[2] -= 0.05
    config = write_config(tmp_path, ctl.host, poses=f"  down: {{tcp_pose: {target}}}\n")
    with Cell(config) as cell:
        with _signal_after(method, signum) as sent, pytest.raises(RAISES[signum]):
            cell.arm.tcp_offset()
        assert sent == [method]
        # The session goes on, every answer with its own call.
        T_flange_tcp = ur_pose_to_matrix(list(TCP_OFFSET))
        T_base_flange = ur_pose_to_matrix(list(ctl.snapshot().tcp_pose)) @ invert(T_flange_tcp)
        np.testing.assert_allclose(cell.arm.flange_pose(), T_base_flange, atol=1e-9)
        np.testing.assert_allclose(cell.arm.tcp_offset(), T_flange_tcp, atol=1e-9)
        assert cell.status().ready
        reached = cell.move_to("down")
    np.testing.assert_allclose(reached, ur_pose_to_matrix(target), atol=1e-6)
    assert [c["kind"] for c in motion_commands(ctl)] == ["moveL"]
