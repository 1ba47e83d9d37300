"""RTDEControlInterface (default flags) against the simulated controller, real ur_rtde 1.6.5.

One controller with instant motion is shared by the module's tests; each test states the pose it
starts from where it matters.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator

import numpy as np
import pytest
import rtde_control
import rtde_receive

from mocks.ur_controller import SimulatedController
from tests.conftest import start_sim_controller
from tests.mock_controller.helpers import HOME_Q, assert_same_pose, pose_matrix, wait_for

# ur5e flange at HOME_Q (nominal DH), tool pointing down.
HOME_FLANGE = [-0.4919, -0.1333, 0.4879, math.pi / math.sqrt(2), math.pi / math.sqrt(2), 0.0]


@pytest.fixture(scope="module")
def ctl() -> Iterator[SimulatedController]:
    controller = start_sim_controller(instant=True)
    yield controller
    controller.stop()


@pytest.fixture
def at_home(control: rtde_control.RTDEControlInterface) -> None:
    """The arm at HOME_Q with no TCP offset."""
    assert control.setTcp([0.0] * 6)
    assert control.moveJ(HOME_Q)


def test_upload_starts_the_program(ctl: SimulatedController,
                                   control: rtde_control.RTDEControlInterface,
                                   receive: rtde_receive.RTDEReceiveInterface) -> None:
    assert control.isConnected()
    assert control.isProgramRunning()
    assert ctl.snapshot().program_running
    assert receive.getRuntimeState() == 2
    assert receive.getRobotStatus() == 3  # power on + program running


def test_movel_sync_reaches_the_target_and_is_recorded(
    ctl: SimulatedController, control: rtde_control.RTDEControlInterface,
    receive: rtde_receive.RTDEReceiveInterface, at_home: None,
) -> None:
    start = receive.getActualTCPPose()
    assert_same_pose(start, HOME_FLANGE, tol=1e-4)
    target = list(start)
    target[0] += 0.05
    target[2] -= 0.1
    before = len(ctl.commands)
    assert control.moveL(target, 0.3, 1.5)
    assert_same_pose(ctl.snapshot().tcp_pose, target)
    wait_for(lambda: np.allclose(receive.getActualTCPPose()[:3], target[:3], atol=1e-9))
    entry = ctl.commands[before]
    assert {k: v for k, v in entry.items() if k != "t"} == {
        "kind": "moveL", "target": target, "speed": 0.3, "accel": 1.5, "async": False}


def test_movej_sync_reaches_the_joints(ctl: SimulatedController,
                                       control: rtde_control.RTDEControlInterface,
                                       receive: rtde_receive.RTDEReceiveInterface) -> None:
    q = [0.2, -1.3, 1.4, -1.6, -1.5, 0.4]
    assert control.moveJ(q, 0.8, 1.0)
    np.testing.assert_allclose(ctl.snapshot().q, q)
    wait_for(lambda: np.allclose(receive.getActualQ(), q))
    assert ctl.commands[-1]["kind"] == "moveJ"
    assert ctl.commands[-1]["target"] == q


def test_movel_fk_and_movej_ik(ctl: SimulatedController,
                               control: rtde_control.RTDEControlInterface, at_home: None) -> None:
    q = [0.1, -1.5, 1.5, -1.5, -1.6, 0.1]
    assert control.moveL_FK(q)
    np.testing.assert_allclose(ctl.snapshot().q, q, atol=1e-9)
    pose = list(ctl.snapshot().tcp_pose)
    pose[1] += 0.05
    assert control.moveJ_IK(pose)
    assert_same_pose(ctl.snapshot().tcp_pose, pose)
    kinds = [c["kind"] for c in ctl.commands[-2:]]
    assert kinds == ["moveL_FK", "moveJ_IK"]
    assert ctl.commands[-1]["target"] == pose


def test_stops_are_recorded(ctl: SimulatedController,
                            control: rtde_control.RTDEControlInterface) -> None:
    before = len(ctl.commands)
    control.stopL(5.0)
    control.stopJ(3.0, True)
    assert control.speedStop(7.0)
    entries = [{k: v for k, v in c.items() if k != "t"} for c in ctl.commands[before:]]
    assert entries == [
        {"kind": "stopL", "accel": 5.0, "async": False},
        {"kind": "stopJ", "accel": 3.0, "async": True},
        {"kind": "speedStop", "accel": 7.0},
    ]
    times = [c["t"] for c in ctl.commands[before:]]
    assert times == sorted(times)


def test_tcp_offset_round_trip_and_actual_tcp_pose(
    ctl: SimulatedController, control: rtde_control.RTDEControlInterface,
    receive: rtde_receive.RTDEReceiveInterface, at_home: None,
) -> None:
    offset = [0.01, -0.02, 0.15, 0.0, 0.0, 0.5]
    assert control.setTcp(offset)
    try:
        np.testing.assert_allclose(control.getTCPOffset(), offset)
        snap = ctl.snapshot()
        assert snap.tcp_offset == tuple(offset)
        expected = pose_matrix(snap.flange_pose) @ pose_matrix(offset)
        wait_for(lambda: np.allclose(pose_matrix(receive.getActualTCPPose()), expected,
                                     atol=1e-9))
        assert_same_pose(control.getForwardKinematics(), receive.getActualTCPPose())
    finally:
        assert control.setTcp([0.0] * 6)


def test_actual_tool_flange_pose_is_stale_on_the_first_call(
    ctl: SimulatedController, control: rtde_control.RTDEControlInterface, at_home: None,
) -> None:
    np.testing.assert_allclose(control.getTCPOffset(), [0.0] * 6)  # zeros in out doubles
    # No-wait id 58: the client reads the result registers right after sending the command.
    assert control.getActualToolFlangePose() == [0.0] * 6
    time.sleep(0.05)
    assert_same_pose(control.getActualToolFlangePose(), ctl.snapshot().flange_pose)


def test_forward_kinematics_forms(ctl: SimulatedController,
                                  control: rtde_control.RTDEControlInterface,
                                  at_home: None) -> None:
    assert_same_pose(control.getForwardKinematics(), HOME_FLANGE, tol=1e-4)
    q = [0.2, -1.2, 1.1, -1.4, -1.5, 0.3]
    assert control.moveJ(q)
    T_base_flange = pose_matrix(control.getForwardKinematics())  # active TCP is zero
    tcp = [0.0, 0.0, 0.2, 0.0, 0.0, 0.3]
    control.poseTrans([0.0] * 6, tcp)  # leaves tcp in input_double_register_6..11
    # The script reads get_forward_kin's TCP from D6-D11. getForwardKinematics(q) sends only q,
    # and 1.6.5 sends (q, tcp) as recipe 6, whose 6 doubles are all that reach the registers:
    # both use whatever an earlier command left in D6-D11, as on a real controller.
    expected = T_base_flange @ pose_matrix(tcp)
    np.testing.assert_allclose(pose_matrix(control.getForwardKinematics(q)), expected, atol=1e-9)
    np.testing.assert_allclose(pose_matrix(control.getForwardKinematics(q, [0.0] * 6)), expected,
                               atol=1e-9)


def test_inverse_kinematics(ctl: SimulatedController,
                            control: rtde_control.RTDEControlInterface, at_home: None) -> None:
    pose = list(HOME_FLANGE)
    pose[2] -= 0.1
    q = control.getInverseKinematics(pose)
    assert np.max(np.abs(np.array(q) - HOME_Q)) < 0.5  # the solution near the current joints
    q_near = [3.0, -1.6, -1.6, 0.0, 1.6, 0.0]
    q2 = control.getInverseKinematics(pose, q_near)
    assert not np.allclose(q, q2)
    for solution in (q, q2):
        assert control.moveJ(solution)
        assert_same_pose(control.getForwardKinematics(), pose)
    assert control.getInverseKinematicsHasSolution(pose)
    assert not control.getInverseKinematicsHasSolution([2.0, 0.0, 0.5, 0.0, math.pi, 0.0])


def test_safety_limits(control: rtde_control.RTDEControlInterface, at_home: None) -> None:
    assert control.isPoseWithinSafetyLimits(HOME_FLANGE)
    assert not control.isPoseWithinSafetyLimits([2.0, 0.0, 0.5, 0.0, math.pi, 0.0])
    assert control.isJointsWithinSafetyLimits(HOME_Q)
    assert not control.isJointsWithinSafetyLimits([7.0, 0.0, 0.0, 0.0, 0.0, 0.0])


def test_pose_trans(control: rtde_control.RTDEControlInterface) -> None:
    p_from = [0.1, 0.2, 0.3, 0.1, -0.2, 0.3]
    p_from_to = [0.05, 0.0, -0.1, 0.0, 0.4, 0.0]
    expected = pose_matrix(p_from) @ pose_matrix(p_from_to)
    np.testing.assert_allclose(pose_matrix(control.poseTrans(p_from, p_from_to)), expected,
                               atol=1e-12)


def test_payload_and_steady(ctl: SimulatedController,
                            control: rtde_control.RTDEControlInterface,
                            receive: rtde_receive.RTDEReceiveInterface) -> None:
    assert control.setPayload(1.5, [0.0, 0.01, 0.05])
    assert ctl.snapshot().payload_kg == 1.5
    wait_for(lambda: receive.getPayload() == 1.5)
    np.testing.assert_allclose(receive.getPayloadCog(), [0.0, 0.01, 0.05])
    assert control.isSteady()


def test_unreachable_movel_stops_the_program_and_a_new_client_recovers(
    ctl: SimulatedController, control: rtde_control.RTDEControlInterface,
) -> None:
    assert not control.moveL([2.0, 0.0, 0.5, 0.0, math.pi, 0.0])
    assert not ctl.snapshot().program_running
    assert control.reuploadScript()
    wait_for(control.isProgramRunning)
    assert control.moveJ(HOME_Q)


def test_upper_range_registers(sim_controller: Callable[..., SimulatedController]) -> None:
    upper = sim_controller(instant=True)
    flags = (rtde_control.RTDEControlInterface.FLAG_UPLOAD_SCRIPT
             | rtde_control.RTDEControlInterface.FLAG_UPPER_RANGE_REGISTERS)
    c = rtde_control.RTDEControlInterface(upper.host, 500.0, flags)
    try:
        target = list(upper.snapshot().tcp_pose)
        target[2] -= 0.05
        assert c.moveL(target)
        assert_same_pose(upper.snapshot().tcp_pose, target)
        assert c.setTcp([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
        np.testing.assert_allclose(c.getTCPOffset(), [0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
    finally:
        c.disconnect()
