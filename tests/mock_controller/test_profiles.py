"""The cb3 and polyscope-x profiles through the real ur_rtde 1.6.5 client (e-series, the default,
is what every other test uses)."""

from __future__ import annotations

import socket
from collections.abc import Callable

import dashboard_client
import numpy as np
import pytest
import rtde_control
import rtde_receive

from mocks.ur_controller import SimulatedController
from tests.mock_controller.helpers import rtde_controller_version, wait_for
from tests.rtde_client.client import RtdeClient

Factory = Callable[..., SimulatedController]


def lowered(pose: list[float], dz_m: float) -> list[float]:
    moved = list(pose)
    moved[2] -= dz_m
    return moved


def test_cb3_runs_ur_rtde_at_125_hz_with_a_cb3_arm(sim_controller: Factory) -> None:
    ctl = sim_controller(profile="cb3", instant=True)
    assert rtde_controller_version(ctl.host)[:2] == (3, 15)
    # A UR5 (CB3), not a UR5e: upper arm up at the home pose, the elbow is d1 + |a2| high.
    with RtdeClient(ctl.host) as client:
        assert client.request_protocol_version(2)
        assert client.setup_outputs(["elbow_position"], 125.0).accepted
        assert client.start()
        assert client.receive()["elbow_position"][2] == pytest.approx(0.089159 + 0.425)
    receive = rtde_receive.RTDEReceiveInterface(ctl.host)  # ur_rtde picks 125 Hz for major 3
    control = rtde_control.RTDEControlInterface(ctl.host)
    try:
        start = receive.getActualTCPPose()
        assert control.moveL(lowered(start, 0.05))
        wait_for(lambda: abs(receive.getActualTCPPose()[2] - (start[2] - 0.05)) < 1e-9)
        stamps = []
        while len(stamps) < 20:
            stamp = receive.getTimestamp()
            if not stamps or stamp != stamps[-1]:
                stamps.append(stamp)
        cycles = np.array(stamps) / 0.008  # CB3 control cycle
        np.testing.assert_allclose(cycles, np.round(cycles), atol=1e-6)
        assert control.getTCPOffset() == [0.0] * 6
    finally:
        control.disconnect()
        receive.disconnect()


def test_cb3_serves_no_e_series_fields(sim_controller: Factory) -> None:
    ctl = sim_controller(profile="cb3", instant=True)
    with pytest.raises(RuntimeError, match="not found"):
        rtde_receive.RTDEReceiveInterface(ctl.host, variables=["timestamp", "ft_raw_wrench"])


def test_cb3_dashboard_reports_its_version_and_has_no_remote_control(
    sim_controller: Factory,
) -> None:
    ctl = sim_controller(profile="cb3", instant=True)
    dashboard = dashboard_client.DashboardClient(ctl.host)
    dashboard.connect()
    try:
        assert dashboard.polyscopeVersion() == "3.15.8.106339"
        assert dashboard.getRobotModel() == "UR5"
    finally:
        dashboard.disconnect()
    with pytest.raises(ValueError, match="no remote control"):
        ctl.set_remote_control(False)


def test_polyscope_x_runs_the_control_script_without_dashboard_or_upload(
    sim_controller: Factory,
) -> None:
    ctl = sim_controller(profile="polyscope-x", instant=True)
    for port in (29999, 30003):  # ur_rtde opens neither on 10.x
        with pytest.raises(ConnectionRefusedError):
            socket.create_connection((ctl.host, port), timeout=5.0)
    receive = rtde_receive.RTDEReceiveInterface(ctl.host)
    control = rtde_control.RTDEControlInterface(ctl.host)
    try:
        assert control.isProgramRunning()  # started on the pendant, as PolyScope X needs
        start = receive.getActualTCPPose()
        assert control.moveL(lowered(start, 0.05))
        assert ctl.snapshot().tcp_pose[2] == pytest.approx(start[2] - 0.05, abs=1e-9)
        ctl.inject("stop-program")  # nothing can start it again from here
        wait_for(lambda: not control.isProgramRunning())
        assert not control.moveL(start)
    finally:
        control.disconnect()
        receive.disconnect()
