"""Motion in real time: async moves and the progress word, straight lines, stops, the watchdog,
the kill path of a second control client, unimplemented commands."""

from __future__ import annotations

import math
import time
from collections.abc import Iterator

import numpy as np
import pytest
import rtde_control
import rtde_io
import rtde_receive

from mocks.ur_controller import SimulatedController
from tests.conftest import start_sim_controller
from tests.mock_controller.helpers import HOME_Q, assert_same_pose, wait_for


@pytest.fixture(scope="module")
def ctl() -> Iterator[SimulatedController]:
    controller = start_sim_controller(initial_q=HOME_Q)  # real-time motion
    yield controller
    controller.stop()


@pytest.fixture
def running(ctl: SimulatedController, control: rtde_control.RTDEControlInterface) -> None:
    """The control script running (an earlier test may have stopped it)."""
    if not ctl.snapshot().program_running:
        assert control.reuploadScript()
        wait_for(control.isProgramRunning)


def test_async_movel_reports_progress_and_follows_a_straight_line(
    ctl: SimulatedController, control: rtde_control.RTDEControlInterface,
    receive: rtde_receive.RTDEReceiveInterface, running: None,
) -> None:
    start = np.array(receive.getActualTCPPose())
    target = start.copy()
    target[:3] += [0.06, 0.0, -0.08]  # 0.1 m at 0.25 m/s: about 0.6 s
    assert control.moveL(target.tolist(), 0.25, 1.2, True)
    assert control.getAsyncOperationProgress() == 0  # running, single move: progress 0
    status = control.getAsyncOperationProgressEx()
    assert status.isAsyncOperationRunning()
    samples = []
    while control.getAsyncOperationProgress() >= 0:
        samples.append(receive.getActualTCPPose())
        time.sleep(0.01)
    assert control.getAsyncOperationProgress() < 0
    assert not control.getAsyncOperationProgressEx().isAsyncOperationRunning()
    assert len(samples) > 10
    direction = (target[:3] - start[:3]) / np.linalg.norm(target[:3] - start[:3])
    for pose in samples:
        offset = np.array(pose[:3]) - start[:3]
        off_line = offset - np.dot(offset, direction) * direction
        assert np.linalg.norm(off_line) < 1e-6  # on the straight line
        assert_same_pose([0, 0, 0, *pose[3:]], [0, 0, 0, *start[3:]], tol=1e-6)
    along = [np.dot(np.array(p[:3]) - start[:3], direction) for p in samples]
    assert along == sorted(along)  # never goes back
    wait_for(lambda: not ctl.snapshot().moving)
    assert_same_pose(ctl.snapshot().tcp_pose, target.tolist())
    assert ctl.commands[-1]["async"] is True


def test_async_movej_interpolates_joints(
    ctl: SimulatedController, control: rtde_control.RTDEControlInterface,
    receive: rtde_receive.RTDEReceiveInterface, running: None,
) -> None:
    q0 = np.array(receive.getActualQ())
    q1 = q0 + np.array([0.3, -0.1, 0.2, 0.0, 0.1, -0.2])
    assert control.moveJ(q1.tolist(), 1.0, 2.0, True)
    fractions = []
    while control.getAsyncOperationProgress() >= 0:
        q = np.array(receive.getActualQ())
        movable = q1 != q0
        s = (q - q0)[movable] / (q1 - q0)[movable]
        np.testing.assert_allclose(s, s[0], atol=1e-9)
        fractions.append(float(s[0]))
        time.sleep(0.01)
    assert fractions == sorted(fractions)
    assert any(0.1 < f < 0.9 for f in fractions)
    wait_for(lambda: np.allclose(receive.getActualQ(), q1))


def test_stopl_halts_an_async_move_midway(
    ctl: SimulatedController, control: rtde_control.RTDEControlInterface,
    receive: rtde_receive.RTDEReceiveInterface, running: None,
) -> None:
    start = np.array(receive.getActualTCPPose())
    target = start.copy()
    target[2] -= 0.3  # about 1.4 s
    assert control.moveL(target.tolist(), 0.25, 1.2, True)
    wait_for(lambda: receive.getActualTCPPose()[2] < start[2] - 0.02)
    control.stopL(10.0)
    assert control.getAsyncOperationProgress() < 0
    snap = ctl.snapshot()
    assert not snap.moving
    assert target[2] < snap.tcp_pose[2] < start[2] - 0.02
    assert [c["kind"] for c in ctl.commands[-2:]] == ["moveL", "stopL"]
    assert control.isSteady()


def test_new_async_move_replaces_the_running_one(
    ctl: SimulatedController, control: rtde_control.RTDEControlInterface,
    receive: rtde_receive.RTDEReceiveInterface, running: None,
) -> None:
    start = np.array(receive.getActualTCPPose())
    first, second = start.copy(), start.copy()
    first[0] += 0.3
    second[1] += 0.05
    assert control.moveL(first.tolist(), 0.25, 1.2, True)
    op_first = control.getAsyncOperationProgressEx().operationId()
    assert control.moveL(second.tolist(), 0.25, 1.2, True)
    assert control.getAsyncOperationProgressEx().operationId() != op_first
    wait_for(lambda: control.getAsyncOperationProgress() < 0)
    snap = ctl.snapshot()
    assert abs(snap.tcp_pose[1] - second[1]) < 1e-9
    assert snap.tcp_pose[0] < first[0] - 0.1  # the first move never finished


def test_watchdog_stops_the_program_when_starved(
    ctl: SimulatedController, control: rtde_control.RTDEControlInterface, running: None,
) -> None:
    assert control.setWatchdog(20.0)
    for _ in range(30):  # 0.3 s of kicks at 100 Hz keeps it alive
        assert control.kickWatchdog()
        time.sleep(0.01)
    assert ctl.snapshot().program_running
    wait_for(lambda: not control.isProgramRunning(), timeout_s=2.0)
    assert ctl.snapshot().runtime_state == 1


def test_unimplemented_command_fails_and_stops_the_program(
    ctl: SimulatedController, control: rtde_control.RTDEControlInterface, running: None,
) -> None:
    assert not control.forceModeStop()  # id 7 is not emulated
    assert not ctl.snapshot().program_running


def test_second_control_client_kills_the_running_program_and_takes_over(
    ctl: SimulatedController, control: rtde_control.RTDEControlInterface, running: None,
) -> None:
    # The module's client keeps its connection: a second one would collide on the input
    # registers (IN_USE), as on a real controller.
    with pytest.raises(RuntimeError, match="already in use"):
        rtde_control.RTDEControlInterface(ctl.host)
    first = start_sim_controller(instant=True)
    try:
        c1 = rtde_control.RTDEControlInterface(first.host)
        c1.disconnect()
        assert first.snapshot().program_running  # the program outlives its client
        c2 = rtde_control.RTDEControlInterface(first.host)
        try:
            assert c2.isProgramRunning()
            assert c2.moveJ(HOME_Q)
        finally:
            c2.disconnect()
    finally:
        first.stop()


@pytest.mark.parametrize(("speed_factor", "slider"), [(2.0, 1.0), (2.0, 0.5)])
def test_movel_honours_speed_speed_factor_and_slider(speed_factor: float, slider: float) -> None:
    """Speed measured against the controller's own timestamps scales with both factors."""
    fast = start_sim_controller(initial_q=HOME_Q, speed_factor=speed_factor)
    try:
        c = rtde_control.RTDEControlInterface(fast.host)
        r = rtde_receive.RTDEReceiveInterface(fast.host)
        io = rtde_io.RTDEIOInterface(fast.host)
        try:
            assert io.setSpeedSlider(slider)
            start = np.array(r.getActualTCPPose())
            target = start.copy()
            target[2] -= 0.25  # cruise phase at v = 0.25 m/s for most of the way
            assert c.moveL(target.tolist(), 0.25, 1.2, True)
            samples: list[tuple[float, float]] = []
            while c.getAsyncOperationProgress() >= 0:
                t0, z, t1 = r.getTimestamp(), r.getActualTCPPose()[2], r.getTimestamp()
                if t0 == t1 and (not samples or t0 > samples[-1][0]):
                    samples.append((t0, z))
                time.sleep(0.01)
        finally:
            io.disconnect()
            r.disconnect()
            c.disconnect()
    finally:
        fast.stop()
    times, heights = np.array(samples).T
    speeds = np.abs(np.diff(heights) / np.diff(times))
    assert len(speeds) > 10
    cruise = 0.25 * speed_factor * slider
    assert np.max(speeds) <= cruise * 1.05
    assert np.max(speeds) >= cruise * 0.9


def test_movel_through_an_unreachable_region_protective_stops_on_the_way() -> None:
    # Both ends are reachable; the straight line between them passes within d4 of the base
    # axis, where a tool-down ur5e has no IK solution.
    start = [-0.4, -0.05, 0.4, math.pi, 0.0, 0.0]
    target = [0.4, -0.05, 0.4, math.pi, 0.0, 0.0]
    ctl = start_sim_controller(initial_flange_pose=start, speed_factor=4.0)
    try:
        c = rtde_control.RTDEControlInterface(ctl.host)
        try:
            assert c.isPoseWithinSafetyLimits(target)
            assert not c.moveL(target, 0.5, 2.0)
        finally:
            c.disconnect()
        snap = ctl.snapshot()
    finally:
        ctl.stop()
    assert snap.safety_mode == 3
    assert not snap.moving
    assert -0.4 < snap.tcp_pose[0] < 0.0  # halted on the way, before the base axis


def test_stopl_brakes_at_its_deceleration(
    ctl: SimulatedController, control: rtde_control.RTDEControlInterface,
    receive: rtde_receive.RTDEReceiveInterface, running: None,
) -> None:
    start = np.array(receive.getActualTCPPose())
    target = start.copy()
    target[2] -= 0.3
    assert control.moveL(target.tolist(), 0.25, 1.2, True)
    wait_for(lambda: receive.getActualTCPPose()[2] < start[2] - 0.1)  # cruising at 0.25 m/s
    z_at_stop = ctl.snapshot().tcp_pose[2]
    control.stopL(0.5, True)  # async: returns while the arm brakes over 0.25^2 / (2 * 0.5) m
    assert control.getAsyncOperationProgress() >= 0  # the stop runs
    wait_for(lambda: control.getAsyncOperationProgress() < 0)
    travel = z_at_stop - ctl.snapshot().tcp_pose[2]
    # 62.5 mm of braking, plus what the arm covers at 0.25 m/s while the stop travels from this
    # client to the controller (up to 0.1 s on a busy shared machine: 25 mm). A stop at another
    # deceleration, or none, lands far outside.
    assert 0.0625 * 0.8 < travel < 0.0625 + 0.25 * 0.1
    assert not ctl.snapshot().moving
    last = ctl.commands[-1]
    assert (last["kind"], last["accel"], last["async"]) == ("stopL", 0.5, True)
