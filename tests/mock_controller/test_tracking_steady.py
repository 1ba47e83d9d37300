"""is_steady() and the opt-in tracking model (lag and measurement noise) of the simulated arm:
the Arm class cycle by cycle, and isSteady and target/actual through ur_rtde."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import rtde_control
import rtde_receive

from mocks.ur_controller import SimulatedController
from mocks.ur_controller.arm import (
    JOINT_NOISE_RAD,
    STEADY_CYCLES,
    TRACKING_LAG_CYCLES,
    Arm,
    default_q,
)
from mocks.ur_controller.kinematics import MODELS
from tests.mock_controller.helpers import HOME_Q, wait_for

CYCLE_S = 0.002


def arm(tracking: bool) -> Arm:
    return Arm(MODELS["ur5e"], default_q(), np.zeros(6), 1.0, False, CYCLE_S,
               tracking_seed=7 if tracking else None)


def cycle(robot: Arm, count: int = 1) -> None:
    for _ in range(count):
        robot.advance(CYCLE_S, robot.now_s + CYCLE_S)


def run_to_rest(robot: Arm) -> int:
    """Cycles until the motion ended (the last one included)."""
    cycles = 0
    while robot.motion is not None:
        cycle(robot)
        cycles += 1
    return cycles


def test_steady_only_once_the_arm_has_been_still_for_a_while() -> None:
    robot = arm(tracking=False)
    assert robot.steady  # at rest since start-up
    robot.move_joint(robot.q + 0.01, 1.0, 2.0, "moveJ")
    assert not robot.steady  # a move in progress
    cycle(robot)
    assert not robot.steady
    run_to_rest(robot)
    assert not robot.steady  # came to rest in this very cycle
    cycle(robot, STEADY_CYCLES - 1)
    assert not robot.steady
    cycle(robot)
    assert robot.steady


def test_with_tracking_steady_waits_for_the_actual_joints_to_catch_up() -> None:
    assert TRACKING_LAG_CYCLES > STEADY_CYCLES  # else this test could not tell the two apart
    robot = arm(tracking=True)
    robot.move_joint(robot.q + 0.01, 1.0, 2.0, "moveJ")
    run_to_rest(robot)
    cycle(robot, TRACKING_LAG_CYCLES - 1)
    assert not robot.steady  # the target has been still long enough, the arm still lags it
    cycle(robot)
    assert robot.steady
    np.testing.assert_allclose(robot.actual_q, robot.q, atol=6 * JOINT_NOISE_RAD)


def test_tracking_lags_the_target_by_its_cycles_during_a_move() -> None:
    robot = arm(tracking=True)
    q0 = robot.q.copy()
    robot.move_joint(q0 + 0.5, 0.5, 20.0, "moveJ")  # cruises at 0.5 rad/s after 25 ms
    cycle(robot, 100)
    lag_rad = robot.q - robot.actual_q
    np.testing.assert_allclose(lag_rad, 0.5 * TRACKING_LAG_CYCLES * CYCLE_S,
                               atol=6 * JOINT_NOISE_RAD)


def test_measurement_noise_has_the_documented_size_and_no_bias() -> None:
    robot = arm(tracking=True)
    samples = []
    for _ in range(2000):
        cycle(robot)
        samples.append(robot.actual_q - robot.q)
    errors = np.array(samples)
    assert 0.9 * JOINT_NOISE_RAD < errors.std() < 1.1 * JOINT_NOISE_RAD
    assert np.all(np.abs(errors.mean(axis=0)) < 0.2 * JOINT_NOISE_RAD)


def test_without_tracking_actual_is_target_exactly() -> None:
    robot = arm(tracking=False)
    robot.move_joint(robot.q + 0.2, 1.0, 2.0, "moveJ")
    cycle(robot, 50)
    assert robot.actual_q is robot.q
    assert np.array_equal(robot.actual_tcp_pose, robot.tcp_pose)


def test_is_steady_through_ur_rtde_is_false_while_moving_and_braking(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    ctl = sim_controller(initial_q=HOME_Q)
    control = rtde_control.RTDEControlInterface(ctl.host)
    try:
        assert control.isSteady()
        target = list(ctl.snapshot().tcp_pose)
        target[2] -= 0.2
        assert control.moveL(target, 0.25, 1.2, True)
        assert not control.isSteady()
        control.stopL(0.5, True)  # brakes over half a second
        assert control.getAsyncOperationProgress() >= 0
        assert not control.isSteady()
        wait_for(lambda: control.getAsyncOperationProgress() < 0)
        wait_for(control.isSteady)
    finally:
        control.disconnect()


def test_tracking_through_rtde_target_and_actual_differ_only_when_asked(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    ctl = sim_controller(initial_q=HOME_Q, tracking=True)
    receive = rtde_receive.RTDEReceiveInterface(ctl.host)
    try:
        actual, target = np.array(receive.getActualQ()), np.array(receive.getTargetQ())
        assert not np.array_equal(actual, target)  # measurement noise
        np.testing.assert_allclose(actual, target, atol=6 * JOINT_NOISE_RAD)
        assert ctl.snapshot().actual_tcp_pose != ctl.snapshot().tcp_pose
    finally:
        receive.disconnect()
