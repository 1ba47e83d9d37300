"""Remote Control across PolyScope versions: the session and ``status`` read it by one rule.

PolyScope 5.6 added Local/Remote Control and the dashboard's ``is in remote control``
(docs/ur-rtde.md, "PolyScope versions"); an older e-Series answers that question with
``Could not understand``, and a CB3 has no such mode either: any client may command them. The
session (``URRtdeArm`` through the real ur_rtde, and a Cell on it) and ``handeye-pick status``
(robot/ur/readout.py, its own sockets) must both read such a controller as remote, and both read
a 5.6+ controller in local control as local.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from handeye_pick.cell.session import Cell
from handeye_pick.detection import load_detection
from handeye_pick.robot.ur.arm import URRtdeArm
from mocks.ur_controller import SimulatedController
from tests.conftest import TEST_WATCHDOG_S
from tests.integration.test_operator_cli import cli_json
from tests.integration.test_pick_cli import DEMO, TCP_OFFSET, write_config

SimFactory = Callable[..., SimulatedController]


def test_a_session_drives_an_e_series_older_than_remote_control(
    sim_controller: SimFactory,
) -> None:
    ctl = sim_controller(profile="e-series-5.4", instant=True)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        assert arm.controller_version.startswith("5.4.")
        assert arm.status().remote_control
        target = arm.tcp_pose()
        target[2, 3] -= 0.05
        reached = arm.move_linear(target, 0.25, 1.2, timeout_s=5.0)
    np.testing.assert_allclose(reached, target, atol=1e-6)
    assert [c["kind"] for c in ctl.commands] == ["moveL"]


def test_a_cell_picks_on_an_e_series_older_than_remote_control(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(profile="e-series-5.4", tcp_offset=TCP_OFFSET, instant=True)
    with Cell(write_config(tmp_path, ctl.host)) as cell:
        status = cell.status()
        assert status.ready, status.problems
        result = cell.pick(load_detection(DEMO / "detection.yaml"))
    assert result.status == "picked"
    assert [c["kind"] for c in ctl.commands] == ["moveL"] * 3  # approach, grasp, retreat


@pytest.mark.parametrize("profile", ["e-series", "e-series-5.4", "cb3"])
def test_the_session_and_status_agree_on_remote_control(
    sim_controller: SimFactory, tmp_path: Path, profile: str
) -> None:
    ctl = sim_controller(profile=profile, tcp_offset=TCP_OFFSET, instant=True)
    config = write_config(tmp_path, ctl.host)
    exit_status, report = cli_json("status", "--config", str(config))
    with Cell(config) as cell:
        session = cell.status()
    assert session.robot is not None
    assert session.robot.remote_control is True
    assert report["remote_control"] is True
    assert not any("Remote Control" in problem for problem in report["problems"]), report
    if profile == "e-series-5.4":
        # status's only objection: a 5.4 controller does not serve tcp_offset over RTDE (5.5.1)
        assert exit_status == 3, report
        assert len(report["problems"]) == 1
        assert "does not serve tcp_offset" in report["problems"][0]
    else:
        assert (exit_status, report["ready"]) == (0, True), report


def test_the_session_and_status_agree_on_local_control(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_config(tmp_path, ctl.host)
    with Cell(config) as cell:
        ctl.set_remote_control(False)  # switched on the pendant during the session
        session = cell.status()
        exit_status, report = cli_json("status", "--config", str(config))
    assert session.robot is not None
    assert session.robot.remote_control is False
    assert any("Remote Control" in problem for problem in session.problems), session.problems
    assert report["remote_control"] is False
    assert exit_status == 3, report
    assert any("Remote Control" in problem for problem in report["problems"]), report
