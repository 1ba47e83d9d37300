"""ur_rtde's controller-side watchdog (setWatchdog, id 35): the control script arms
rtde_set_watchdog("input_int_register_0", f, "stop"), so the controller stops the program, and
with it the arm, once a client goes 1/f s without writing that register."""

from __future__ import annotations

import time
from collections.abc import Callable

import pytest
import rtde_control

from mocks.ur_controller import SimulatedController
from tests.mock_controller.helpers import HOME_Q, wait_for

CYCLE_S = 0.002


@pytest.mark.parametrize("frequency_hz", [20.0, 30.0])
def test_a_client_that_goes_silent_has_the_arm_stopped_within_one_period_and_a_cycle(
    sim_controller: Callable[..., SimulatedController], frequency_hz: float,
) -> None:
    ctl = sim_controller(initial_q=HOME_Q)  # real-time motion
    control = rtde_control.RTDEControlInterface(ctl.host)
    try:
        assert control.setWatchdog(frequency_hz)
        start = ctl.snapshot().tcp_pose
        target = list(start)
        target[2] -= 0.3
        assert control.moveL(target, 0.1, 1.0, True)  # 3 s of motion; then the client is silent
        wait_for(lambda: not ctl.snapshot().program_running)
        snap = ctl.snapshot()
        (motion,) = ctl.motions
    finally:
        control.disconnect()
    assert motion["end"].startswith("program stopped: RTDE watchdog")
    assert motion["watchdog_min_frequency_hz"] == frequency_hz
    silence_s = motion["end_t"] - motion["watchdog_last_update_t"]
    assert 1.0 / frequency_hz < silence_s <= 1.0 / frequency_hz + CYCLE_S + 1e-9
    assert not snap.moving
    assert snap.runtime_state == 1
    assert snap.tcp_pose[2] > target[2] + 0.25  # stopped at the start of a 0.3 m move


def test_kicks_keep_the_program_running_while_a_synchronous_move_blocks_the_script(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    # A synchronous move sends nothing while it runs: the watchdog is checked all the same.
    ctl = sim_controller(initial_q=HOME_Q)
    control = rtde_control.RTDEControlInterface(ctl.host)
    try:
        assert control.setWatchdog(10.0)
        target = list(ctl.snapshot().tcp_pose)
        target[2] -= 0.1
        assert not control.moveL(target, 0.1, 1.0)  # 1.1 s without an update: stopped
        (motion,) = ctl.motions
        assert motion["end"].startswith("program stopped: RTDE watchdog")
    finally:
        control.disconnect()


def test_a_new_program_starts_without_a_watchdog(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    ctl = sim_controller(instant=True)
    control = rtde_control.RTDEControlInterface(ctl.host)
    try:
        assert control.setWatchdog(50.0)
        wait_for(lambda: not control.isProgramRunning())
        assert control.reuploadScript()  # watchdogs are removed on program stop
        wait_for(control.isProgramRunning)
        target = list(ctl.snapshot().tcp_pose)
        target[2] -= 0.05
        assert control.moveL(target)
        time.sleep(0.2)  # ten watchdog periods without a write
        assert ctl.snapshot().program_running
    finally:
        control.disconnect()
