"""RTDEReceiveInterface and DashboardClient against the simulated controller (real ur_rtde)."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import dashboard_client
import numpy as np
import pytest
import rtde_receive

from mocks.ur_controller import SimulatedController
from tests.conftest import start_sim_controller
from tests.mock_controller.helpers import (
    assert_same_pose,
    pose_matrix,
    rtde_controller_version,
)

Q_START = (0.1, -1.4, 1.3, -1.5, -1.6, 0.2)
TCP = (0.0, 0.0, 0.15, 0.0, 0.0, 0.3)


@pytest.fixture(scope="module")
def ctl() -> Iterator[SimulatedController]:
    controller = start_sim_controller(initial_q=Q_START, tcp_offset=TCP, instant=True)
    yield controller
    controller.stop()


def test_default_variables_match_the_controller_state(
    ctl: SimulatedController, receive: rtde_receive.RTDEReceiveInterface
) -> None:
    snap = ctl.snapshot()
    np.testing.assert_allclose(receive.getActualQ(), Q_START)
    np.testing.assert_allclose(receive.getTargetQ(), Q_START)
    assert_same_pose(receive.getActualTCPPose(), snap.tcp_pose)
    assert_same_pose(receive.getTargetTCPPose(), snap.tcp_pose)
    assert receive.getRobotMode() == 7
    assert receive.getSafetyMode() == 1
    assert receive.getRuntimeState() == 1  # no program yet
    assert receive.getRobotStatus() == 1  # powered on, no program running
    assert receive.getSafetyStatusBits() == 1
    assert not receive.isProtectiveStopped()
    assert not receive.isEmergencyStopped()
    assert receive.getPayload() == 0.0
    assert receive.getTimestamp() > 0.0


def test_tcp_pose_includes_the_tcp_offset(
    ctl: SimulatedController, receive: rtde_receive.RTDEReceiveInterface
) -> None:
    snap = ctl.snapshot()
    expected = pose_matrix(snap.flange_pose) @ pose_matrix(TCP)
    np.testing.assert_allclose(pose_matrix(receive.getActualTCPPose()), expected, atol=1e-9)
    assert snap.tcp_offset == TCP


def test_custom_variable_list(ctl: SimulatedController) -> None:
    r = rtde_receive.RTDEReceiveInterface(
        ctl.host, variables=["timestamp", "actual_q", "robot_mode", "payload_cog", "safety_mode"]
    )
    try:
        np.testing.assert_allclose(r.getActualQ(), Q_START)
        assert r.getRobotMode() == 7
        assert r.getSafetyMode() == 1
        assert list(r.getPayloadCog()) == [0.0, 0.0, 0.0]
        with pytest.raises(RuntimeError, match="actual_TCP_pose"):
            r.getActualTCPPose()
    finally:
        r.disconnect()


def test_unknown_variable_is_not_found(ctl: SimulatedController) -> None:
    with pytest.raises(RuntimeError, match="not found"):
        rtde_receive.RTDEReceiveInterface(ctl.host, variables=["actual_q", "no_such_variable"])


def test_polyscope_version_is_the_same_on_rtde_and_dashboard(ctl: SimulatedController) -> None:
    d = dashboard_client.DashboardClient(ctl.host)
    d.connect()
    try:
        assert d.polyscopeVersion() == ".".join(map(str, rtde_controller_version(ctl.host)))
        assert d.polyscopeVersion().startswith("5.15.")
        assert d.getSerialNumber().isdigit()
    finally:
        d.disconnect()


def test_dashboard_reports_consistent_state(ctl: SimulatedController) -> None:
    d = dashboard_client.DashboardClient(ctl.host)
    d.connect()
    try:
        assert d.isInRemoteControl()
        assert d.robotmode() == "Robotmode: RUNNING"
        assert d.safetystatus() == "Safetystatus: NORMAL"
        assert not d.running()
        assert d.programState().startswith("STOPPED")
        ctl.set_remote_control(False)
        assert not d.isInRemoteControl()
        assert not ctl.snapshot().remote_control
        ctl.set_remote_control(True)
        assert d.isInRemoteControl()
    finally:
        d.disconnect()


def test_dashboard_power_cycle(sim_controller: Callable[..., SimulatedController]) -> None:
    ctl = sim_controller(instant=True)
    d = dashboard_client.DashboardClient(ctl.host)
    d.connect()
    try:
        d.powerOff()
        assert ctl.snapshot().robot_mode == 3
        d.powerOn()
        assert ctl.snapshot().robot_mode == 5
        d.brakeRelease()
        assert ctl.snapshot().robot_mode == 7
        d.stop()  # "Stopped" even with nothing running, as ur_rtde's kill path needs
        with pytest.raises(RuntimeError):
            d.play()  # nothing loaded, nothing paused
    finally:
        d.disconnect()


def test_non_loopback_host_is_refused() -> None:
    ctl = SimulatedController(host="10.1.2.3")
    with pytest.raises(RuntimeError, match="did not start: exit code 2"):
        ctl.start()
