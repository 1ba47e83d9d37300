"""URRtdeArm through the real ur_rtde 1.6.5 wheel against the simulated controller.

ur_rtde runs in the adapter's child process, so a drop that sends ur_rtde into its reconnect
loop (or a segfault) can only end that child; these tests run the adapter in the test process
itself and check it survives.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from handeye_pick.errors import RobotConnectionError, RobotFault, SafetyRefusal
from handeye_pick.geometry import Transform, ur_pose_to_matrix
from handeye_pick.robot.port import OutputBank, RuntimeState, SafetyMode
from handeye_pick.robot.ur.arm import URRtdeArm
from mocks.ur_controller import SimulatedController
from tests.conftest import TEST_WATCHDOG_S

SimFactory = Callable[..., SimulatedController]
TCP_OFFSET = (0.01, -0.02, 0.15, 0.0, 0.0, 0.4)  # shifted, and turned about the tool axis
MOTION_KINDS = {"moveL", "moveJ", "moveL_FK", "moveJ_IK"}


def _lowered(T_base_tcp: Transform, metres: float) -> Transform:
    T = T_base_tcp.copy()
    T[2, 3] -= metres
    return T


def _eventually(condition: Callable[[], bool], within_s: float = 5.0) -> bool:
    """The IO interface's setters return once the package is sent, not applied: poll."""
    deadline = time.monotonic() + within_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def _assert_pose_close(T: Transform, ur_pose: Any, atol: float = 1e-6) -> None:
    """Compare as matrices: rotation vectors near pi may differ in sign and still agree."""
    np.testing.assert_allclose(T, ur_pose_to_matrix(list(ur_pose)), atol=atol)


def test_flange_and_tcp_with_a_non_zero_tcp_offset(sim_controller: SimFactory) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        snapshot = ctl.snapshot()
        _assert_pose_close(arm.tcp_offset(), TCP_OFFSET)
        _assert_pose_close(arm.flange_pose(), snapshot.flange_pose)
        _assert_pose_close(arm.tcp_pose(), snapshot.tcp_pose)
        status = arm.status()
    assert status.controller_version.startswith("5.")
    assert status.remote_control
    assert status.safety_mode == SafetyMode.NORMAL
    assert status.runtime_state == RuntimeState.PLAYING
    assert not status.protective_stopped
    assert not status.emergency_stopped


def test_flange_is_fresh_after_a_move(sim_controller: SimFactory) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        target = _lowered(arm.tcp_pose(), 0.05)
        reached = arm.move_linear(target, 0.25, 1.2, timeout_s=5.0)
        np.testing.assert_allclose(reached, target, atol=1e-6)
        _assert_pose_close(arm.flange_pose(), ctl.snapshot().flange_pose)
    (move,) = ctl.commands
    assert move["kind"] == "moveL"
    assert move["async"] is True
    assert (move["speed"], move["accel"]) == (0.25, 1.2)
    _assert_pose_close(target, move["target"])


def test_progress_rises_to_one(sim_controller: SimFactory) -> None:
    ctl = sim_controller(speed_factor=4.0)
    fractions: list[float] = []
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        arm.move_linear(_lowered(arm.tcp_pose(), 0.10), 0.25, 1.2, 5.0, fractions.append)
    assert fractions[-1] == 1.0
    assert fractions == sorted(fractions)
    assert any(0.0 < f < 1.0 for f in fractions)


def test_safety_queries(sim_controller: SimFactory) -> None:
    ctl = sim_controller(instant=True)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        near = _lowered(arm.tcp_pose(), 0.05)
        far = near.copy()
        far[:3, 3] = [3.0, 0.0, 0.3]  # beyond a UR5e's reach
        assert arm.is_pose_within_safety_limits(near)
        assert arm.has_ik_solution(near)
        assert not arm.has_ik_solution(far)
    assert ctl.commands == []


@pytest.mark.parametrize(
    ("bank", "field"),
    [(OutputBank.TOOL, "tool_digital_out"), (OutputBank.STANDARD, "standard_digital_out")],
)
def test_digital_output(sim_controller: SimFactory, bank: OutputBank, field: str) -> None:
    ctl = sim_controller(instant=True)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S, with_io=True) as arm:
        arm.set_digital_output(bank, 1, True)
        assert _eventually(lambda: getattr(ctl.snapshot(), field) == 0b10)
        arm.set_digital_output(bank, 1, False)
        assert _eventually(lambda: getattr(ctl.snapshot(), field) == 0)


@pytest.mark.parametrize(
    ("fault", "safety_mode"),
    [
        ("protective-stop@move:1:0.3", SafetyMode.PROTECTIVE_STOP),
        ("emergency-stop@move:1:0.3", SafetyMode.ROBOT_EMERGENCY_STOP),
        ("safeguard-stop@move:1:0.3", SafetyMode.SAFEGUARD_STOP),
        ("stop-program@move:1:0.3", SafetyMode.NORMAL),
    ],
)
def test_fault_during_a_move_is_a_robot_fault_with_state(
    sim_controller: SimFactory, fault: str, safety_mode: int
) -> None:
    ctl = sim_controller(speed_factor=4.0, inject=(fault,))
    with (
        URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm,
        pytest.raises(RobotFault) as caught,
    ):
        arm.move_linear(_lowered(arm.tcp_pose(), 0.10), 0.25, 1.2, timeout_s=5.0)
    assert caught.value.safety_mode == safety_mode
    assert str(ctl.host) in str(caught.value)
    kinds = [c["kind"] for c in ctl.commands]
    assert kinds[0] == "moveL"
    assert not MOTION_KINDS & set(kinds[1:])  # after the fault: stops at most


def test_connection_drop_ends_the_session_and_leaves_this_process_alive(
    sim_controller: SimFactory,
) -> None:
    ctl = sim_controller(speed_factor=2.0, inject=("drop-connection@move:1:0.3",))
    arm = URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S)
    try:
        with pytest.raises(RobotConnectionError, match=r"dropped|no RTDE data|process"):
            arm.move_linear(_lowered(arm.tcp_pose(), 0.10), 0.25, 1.2, timeout_s=5.0)
        with pytest.raises(RobotConnectionError, match="session is over"):
            arm.tcp_pose()
        arm.stop_linear(10.0)  # best effort on a dead link: never raises
    finally:
        arm.close()
        arm.close()
    snapshot = ctl.snapshot()
    assert not snapshot.moving  # stopped through a fresh dashboard connection
    assert [c["kind"] for c in ctl.commands if c["kind"] in MOTION_KINDS] == ["moveL"]


def test_stalled_stream_is_a_lost_link(sim_controller: SimFactory) -> None:
    ctl = sim_controller(speed_factor=1.0, inject=("stall:1.5@move:1:0.2",))
    with (
        URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm,
        pytest.raises(RobotConnectionError, match="no RTDE data"),
    ):
        arm.move_linear(_lowered(arm.tcp_pose(), 0.10), 0.25, 1.2, timeout_s=5.0)
    assert [c["kind"] for c in ctl.commands if c["kind"] in MOTION_KINDS] == ["moveL"]


def test_timeout_sends_stopl(sim_controller: SimFactory) -> None:
    ctl = sim_controller(speed_factor=0.5)
    with (
        URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm,
        pytest.raises(RobotFault, match="did not finish"),
    ):
        arm.move_linear(_lowered(arm.tcp_pose(), 0.10), 0.25, 1.2, timeout_s=0.3)
    assert [c["kind"] for c in ctl.commands] == ["moveL", "stopL"]
    assert not ctl.snapshot().moving


def test_slow_controller_answer_ends_the_session(sim_controller: SimFactory) -> None:
    ctl = sim_controller(instant=True)
    # The call limit (1 s) runs out before the controller's watchdog window (2 s) would.
    with URRtdeArm(ctl.host, watchdog_s=2.0, call_timeout_s=1.0) as arm:
        ctl.inject("slow:3")
        with pytest.raises(RobotConnectionError, match="no answer"):
            arm.has_ik_solution(arm.tcp_pose())
        with pytest.raises(RobotConnectionError, match="session is over"):
            arm.status()


def test_ctrl_c_during_a_move_sends_stopl_and_propagates(sim_controller: SimFactory) -> None:
    ctl = sim_controller(speed_factor=1.0)

    def interrupt_halfway(fraction: float) -> None:
        if fraction > 0.2:
            raise KeyboardInterrupt

    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        with pytest.raises(KeyboardInterrupt):
            arm.move_linear(_lowered(arm.tcp_pose(), 0.10), 0.25, 1.2, 5.0, interrupt_halfway)
        assert arm.status().runtime_state == RuntimeState.PLAYING  # session still usable
    stop = ctl.commands[-1]
    assert stop["kind"] == "stopL"
    assert stop["accel"] == 10.0
    assert not ctl.snapshot().moving


class _CtrlCAt:
    """The arm's pipe end, with one Ctrl-C (SIGINT to this process) arriving just after the
    next ``send`` or ``recv`` has moved its whole message: the hold delivers it as the message's
    hold ends, the worst moment for the bookkeeping of which answer belongs to which call."""

    def __init__(self, connection: Any, method: str) -> None:
        self._connection = connection
        self._method = method

    def __getattr__(self, name: str) -> Any:
        call = getattr(self._connection, name)
        if name != self._method:
            return call

        def then_ctrl_c(*args: Any) -> Any:
            result = call(*args)
            self._method = ""  # once
            os.kill(os.getpid(), signal.SIGINT)
            return result

        return then_ctrl_c


@pytest.mark.parametrize("method", ["send", "recv"])
def test_ctrl_c_right_after_a_message_keeps_answers_with_their_calls(
    sim_controller: SimFactory, method: str
) -> None:
    # Seen as a SIGTERM whose stopL never left: the answer of the interrupted call had been read,
    # the next call waited for it again, 5 s, while the idle ur_rtde process kept the watchdog fed.
    tcp_offset = (0.0, 0.0, 0.12, 0.0, 0.0, 0.3)
    ctl = sim_controller(tcp_offset=tcp_offset, instant=True)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S, call_timeout_s=3.0) as arm:
        connection = arm._child._conn
        arm._child._conn = _CtrlCAt(connection, method)
        with pytest.raises(KeyboardInterrupt):
            arm.tcp_pose()
        arm._child._conn = connection
        np.testing.assert_allclose(arm.tcp_offset(), ur_pose_to_matrix(list(tcp_offset)), atol=1e-9)
        assert arm.status().runtime_state == RuntimeState.PLAYING  # the session goes on


def test_remote_control_off_is_refused_at_connect(sim_controller: SimFactory) -> None:
    ctl = sim_controller(remote_control=False)
    with pytest.raises(SafetyRefusal, match="Remote Control"):
        URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S)


def test_refused_rtde_start_is_a_connection_error(sim_controller: SimFactory) -> None:
    # ur_rtde's receive interface comes back from a refused start without data, its getters
    # returning zeros: that must not pass for a robot at the origin.
    ctl = sim_controller(instant=True, inject=("refuse-start",))
    with pytest.raises(RobotConnectionError, match="no RTDE data"):
        URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S)


def test_nothing_listening_is_a_connection_error(loopback_host: str) -> None:
    # The session's dashboard connection is the first thing it opens.
    with pytest.raises(RobotConnectionError, match=r"dashboard server \(port 29999\)"):
        URRtdeArm(loopback_host, watchdog_s=TEST_WATCHDOG_S)


def test_protective_stop_refuses_a_move(sim_controller: SimFactory) -> None:
    ctl = sim_controller(instant=True)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        target = _lowered(arm.tcp_pose(), 0.05)
        ctl.inject("protective-stop")
        assert _eventually(lambda: arm.status().protective_stopped)  # RTDE shows it a cycle later
        with pytest.raises(RobotFault) as caught:
            arm.move_linear(target, 0.25, 1.2, timeout_s=5.0)
    assert caught.value.safety_mode == SafetyMode.PROTECTIVE_STOP
    assert [c["kind"] for c in ctl.commands if c["kind"] in MOTION_KINDS] == []


def test_no_move_is_sent_after_a_drop_between_moves(sim_controller: SimFactory) -> None:
    # ur_rtde's control interface reconnects by itself after a drop; no motion may go through
    # it, whichever layer (our link check, ur_rtde's own program check) catches it first.
    ctl = sim_controller(instant=True)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        target = _lowered(arm.tcp_pose(), 0.05)
        ctl.inject("drop-connection")
        assert _eventually(lambda: ctl.commands == [] and not ctl.snapshot().moving)
        time.sleep(0.5)  # let ur_rtde's own reconnect attempt run
        with pytest.raises(RobotConnectionError):
            arm.move_linear(target, 0.25, 1.2, timeout_s=5.0)
    assert motion_kinds(ctl) == []


def motion_kinds(ctl: SimulatedController) -> list[str]:
    return [c["kind"] for c in ctl.commands if c["kind"] in MOTION_KINDS]


def test_second_client_is_told_who_holds_the_registers(sim_controller: SimFactory) -> None:
    ctl = sim_controller(instant=True)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as first:
        with pytest.raises(RobotConnectionError, match="held by another RTDE client"):
            URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S)
        assert first.status().runtime_state == RuntimeState.PLAYING  # the first one still works


def test_a_crashed_ur_rtde_process_is_a_connection_error(sim_controller: SimFactory) -> None:
    # What a segfault in ur_rtde's reconnect loop looks like from here.
    ctl = sim_controller(instant=True)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        arm._child._process.kill()  # the child that holds ur_rtde
        with pytest.raises(RobotConnectionError, match=r"died|closed its pipe|is gone"):
            arm.tcp_pose()
        with pytest.raises(RobotConnectionError, match="session is over"):
            arm.status()


def test_timeout_stretches_with_the_speed_slider(sim_controller: SimFactory) -> None:
    ctl = sim_controller()
    # The pendant's slider, set the way a person's tablet or PLC would: another RTDE client.
    slider = "import rtde_io, sys; io = rtde_io.RTDEIOInterface(sys.argv[1]); "
    slider += "sys.exit(0 if io.setSpeedSlider(0.25) else 1)"
    subprocess.run([sys.executable, "-c", slider, ctl.host], check=True, timeout=30)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        target = _lowered(arm.tcp_pose(), 0.10)  # 0.61 s at full speed, 2.4 s at 25 %
        # 1.6 s: short of the move at full speed, so only a timeout stretched by the slider
        # (6.4 s) lets it end; the margin over 2.4 s holds on a loaded machine.
        reached = arm.move_linear(target, 0.25, 1.2, timeout_s=1.6)
    np.testing.assert_allclose(reached, target, atol=1e-6)
