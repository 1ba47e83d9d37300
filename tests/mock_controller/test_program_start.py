"""ur_rtde's control script at its start, cycle by cycle (program.py), without sockets: the 255
that stopped the previous program may still be in the command register when the new one starts
(ur_rtde clears it before it uploads, but the clear can land a cycle after the start on a
simulator that starts at once), and must not stop the new program; a 255 written after the
start must."""

from __future__ import annotations

import numpy as np

from mocks.ur_controller import kinematics as kin
from mocks.ur_controller.arm import Arm
from mocks.ur_controller.path_plan import PathPlanner
from mocks.ur_controller.program import STOP_SCRIPT, ControlScript, Registers
from mocks.ur_controller.record import CommandRecord
from tests.mock_controller.helpers import HOME_Q

CYCLE_S = 0.002


def _script(registers: Registers, started_s: float) -> ControlScript:
    arm = Arm(kin.MODELS["ur5e"], np.array(HOME_Q), np.zeros(6), 1.0, True, CYCLE_S)
    return ControlScript(
        registers, arm, CommandRecord(), 0, lambda _: None, lambda: False, started_s,
        PathPlanner(),
    )


def _write(registers: Registers, value: int, arrived_s: float, now_s: float) -> None:
    """A client's write to input int register 0, taken in at the cycle at ``now_s``."""
    registers.in_int[0] = value
    registers.in_int_fresh[0] = arrived_s
    registers.take_in_writes(now_s)


def test_the_255_left_from_the_previous_program_does_not_stop_the_new_one() -> None:
    registers = Registers()
    # A late loop catching up: the 255 arrived by the wall clock at 1.010 s, its cycle ran at
    # 1.000 s, and the new program starts at 1.004 s, before the stamp of the write it follows.
    _write(registers, STOP_SCRIPT, arrived_s=1.010, now_s=1.000)
    script = _script(registers, started_s=1.004)
    for k in range(5):
        script.cycle(1.004 + k * CYCLE_S)
    assert script.running


def test_a_255_written_after_the_start_stops_the_program() -> None:
    registers = Registers()
    script = _script(registers, started_s=1.0)
    script.cycle(1.0)
    _write(registers, STOP_SCRIPT, arrived_s=1.002, now_s=1.002)
    script.cycle(1.002)
    assert not script.running
