"""One dashboard client: a session asks PolyScope's version and Remote Control on its own
connection only (robot/ur/dashboard.py), the ur_rtde child opens none of its own, and a dashboard
that goes away mid-session ends the session with a typed one-line error and the arm stopped.

Through the real ur_rtde 1.6.5 wheel against the simulated controller, which records every
dashboard connection and its request lines (admin request ``dashboard``). ur_rtde's control
interface connects to the dashboard by itself while it connects (docs/ur-rtde.md, "Dashboard
server"): that connection is ur_rtde's, and these tests name what it may ask.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from handeye_pick.errors import RobotConnectionError, RobotFault
from handeye_pick.robot.port import RuntimeState
from handeye_pick.robot.ur.arm import URRtdeArm
from handeye_pick.robot.ur.child import Child
from mocks.ur_controller import SimulatedController, admin
from tests.conftest import TEST_WATCHDOG_S
from tests.integration.test_pick_cli import (
    DEMO,
    TCP_OFFSET,
    motion_commands,
    run_pick,
    write_config,
)

SimFactory = Callable[..., SimulatedController]
UR_RTDE_CONNECT_CHECK = {
    "e-series": ["PolyscopeVersion", "get serial number"],
    "e-series-5.4": [],  # below 5.6 ur_rtde reads the banner and asks nothing
}
"""What ur_rtde's control interface asks on its own dashboard connection while it connects, told
not to ask Remote Control (the session asked it already)."""


def dashboard_connections(ctl: SimulatedController) -> list[dict[str, Any]]:
    """Every dashboard connection the controller accepted, in order, with its requests."""
    connections: list[dict[str, Any]] = admin.request(ctl.host, {"op": "dashboard"})
    return connections


def _eventually(condition: Callable[[], bool], within_s: float = 10.0) -> bool:
    deadline = time.monotonic() + within_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


@pytest.mark.parametrize(
    ("profile", "remote_asks"),
    [("e-series", 4), ("e-series-5.4", 0)],  # 5.4 has no Remote Control to ask about
)
def test_a_session_asks_version_and_remote_control_on_one_connection(
    sim_controller: SimFactory, profile: str, remote_asks: int
) -> None:
    ctl = sim_controller(profile=profile, instant=True)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        arm.status()
        target = arm.tcp_pose()
        target[2, 3] -= 0.02
        arm.move_linear(target, 0.25, 1.2, timeout_s=5.0)
        arm.status()
        arm.remote_control()
        during = dashboard_connections(ctl)
    # The session's own connection is the first one opened, before ur_rtde's: the version once,
    # Remote Control at connect (the refusal of Local mode) and at every ask since.
    session, *others = during
    assert session["requests"] == ["PolyscopeVersion"] + ["is in remote control"] * remote_asks
    assert [c["requests"] for c in others] == [UR_RTDE_CONNECT_CHECK[profile]]
    assert _eventually(lambda: not any(c["open"] for c in dashboard_connections(ctl)))
    assert len(dashboard_connections(ctl)) == 2  # closing opened none


@pytest.mark.parametrize("profile", ["e-series", "e-series-5.4"])
def test_the_ur_rtde_child_opens_no_dashboard_connection_of_its_own(
    sim_controller: SimFactory, profile: str
) -> None:
    # The child alone, without the session around it: its only dashboard traffic is the control
    # interface's own connect check. No DashboardClient, no Remote Control, no version asked.
    ctl = sim_controller(profile=profile, instant=True)
    child = Child(
        ctl.host,
        with_io=False,
        watchdog_s=TEST_WATCHDOG_S,
        connect_timeout_s=20.0,
        call_timeout_s=6.0,
    )
    try:
        child.call("sample")
        child.call("tcp_offset")
        with pytest.raises(RobotFault, match="KeyError"):  # the operation is gone from the child
            child.call("remote_control")
    finally:
        child.close()
    requests = [c["requests"] for c in dashboard_connections(ctl)]
    assert requests == [UR_RTDE_CONNECT_CHECK[profile]]


def test_a_dashboard_that_goes_away_ends_the_session_with_the_arm_stopped(
    sim_controller: SimFactory,
) -> None:
    ctl = sim_controller(instant=True)
    arm = URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S)
    try:
        assert arm.remote_control()
        ctl.inject("dashboard-down")
        with pytest.raises(RobotConnectionError) as caught:
            arm.remote_control()
        message = str(caught.value)
        assert "\n" not in message
        assert "dashboard server (port 29999) stopped answering" in message
        assert "session is over" in message
        for later in (arm.status, arm.tcp_pose, arm.remote_control):
            with pytest.raises(RobotConnectionError, match="session is over"):
                later()
    finally:
        arm.close()
        arm.close()
    # stopL while the RTDE link still listened, then the ended child's starved watchdog stopped
    # the program.
    assert [c["kind"] for c in ctl.commands] == ["stopL"]
    assert _eventually(lambda: ctl.snapshot().runtime_state == RuntimeState.STOPPED)
    assert not ctl.snapshot().moving


def test_a_dashboard_gone_mid_pick_ends_it_in_one_line_with_the_arm_stopped(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    # Gone halfway through the grasp move: the move ends, and the Remote Control check before
    # the retreat finds no dashboard. Exit 4, one line on stderr, no traceback, no third move.
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET, speed_factor=4.0, inject=("dashboard-down@move:2:0.5",)
    )
    result = run_pick(write_config(tmp_path, ctl.host), "--detection", str(DEMO / "detection.yaml"))
    assert result.returncode == 4, result.stderr
    assert "Traceback" not in result.stderr
    (error,) = [line for line in result.stderr.splitlines() if "29999" in line]
    assert "stopped answering" in error
    assert len(motion_commands(ctl)) == 2
    assert _eventually(lambda: ctl.snapshot().runtime_state == RuntimeState.STOPPED)
    assert not ctl.snapshot().moving
