"""``plan --plot``, ``status`` and ``touch-test`` end to end: the CLI in a subprocess, the real
ur_rtde, the simulated UR.

Expected frames come from the controller's own snapshot and the calibration file, never from the
code under test; motions are checked in the controller's command record.
"""

from __future__ import annotations

import json
import os
import pty
import socket
import subprocess
from collections.abc import Callable
from pathlib import Path
from typing import Any

import matplotlib.image
import numpy as np
import pytest

from handeye_pick.geometry import ur_pose_to_matrix
from handeye_pick.hand_eye.files import load_hand_eye
from handeye_pick.plot import FIGURE_SIZE_PX
from handeye_pick.robot.port import RuntimeState
from handeye_pick.robot.ur.arm import URRtdeArm
from mocks.ur_controller import SimulatedController
from tests.conftest import TEST_WATCHDOG_S
from tests.integration.test_pick_cli import CLI, audit_records

SimFactory = Callable[..., SimulatedController]
ROOT = Path(__file__).resolve().parents[2]
HAND_EYE = ROOT / "config" / "demo" / "hand_eye.yaml"  # eye-in-hand T_flange_cam, mm
TCP_OFFSET = (0.0, 0.0, 0.12, 0.0, 0.0, 0.0)
GRASP_SPEED_MPS = 0.04
POINT_CAM_MM = ("30", "-20", "380")


def write_config(
    tmp_path: Path, host: str, tcp_offset: tuple[float, ...] = TCP_OFFSET, gripper: str = ""
) -> Path:
    path = tmp_path / "cell.yaml"
    path.write_text(
        f"robot:\n  host: {host}\n  tcp_offset: {list(tcp_offset)}\n"
        f"  watchdog_s: {TEST_WATCHDOG_S}\n{gripper}"
        f"hand_eye:\n  mode: eye-in-hand\n  file: {HAND_EYE}\n  units: mm\n"
        "grasp:\n  approach_mm: 100\n  retreat_mm: 100\n"
        f"motion:\n  speed_mps: 0.25\n  accel_mps2: 1.2\n  grasp_speed_mps: {GRASP_SPEED_MPS}\n"
        "workspace:\n  min_mm: [-800, -800, 20]\n  max_mm: [800, 800, 700]\n  max_tilt_deg: 30\n"
        "audit:\n  file: picks.jsonl\n"
    )
    return path


def cli(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*CLI, *args],
        cwd=ROOT,
        input=stdin,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )


def cli_json(*args: str) -> tuple[int, dict[str, Any]]:
    result = cli(*args, "--json")
    return result.returncode, json.loads(result.stdout)


def expected_point_base_m(ctl: SimulatedController) -> np.ndarray:
    """The camera point in base from the controller's own flange and the calibration file."""
    T_flange_cam = load_hand_eye(HAND_EYE, "eye-in-hand", "mm").T_cal
    T_base_cam = ur_pose_to_matrix(list(ctl.snapshot().flange_pose)) @ T_flange_cam
    p_cam_m = np.array([float(v) for v in POINT_CAM_MM]) / 1000.0
    return np.asarray(T_base_cam[:3, :3] @ p_cam_m + T_base_cam[:3, 3])


# --- status -------------------------------------------------------------------------------------


def test_status_ready(sim_controller: SimFactory, tmp_path: Path) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    status, report = cli_json("status", "--config", str(write_config(tmp_path, ctl.host)))
    assert status == 0, report
    assert report["ready"] is True
    assert report["problems"] == []
    assert report["controller_version"]
    # status starts no program: the controller's runtime state is the one it was found in
    assert (report["robot_mode"], report["safety_mode"], report["runtime_state"]) == (
        "RUNNING",
        "NORMAL",
        "STOPPED",
    )
    assert report["remote_control"] is True
    assert report["tcp_offset_matches"] is True
    flange = ur_pose_to_matrix(list(ctl.snapshot().flange_pose))
    np.testing.assert_allclose(ur_pose_to_matrix(report["flange_pose"]), flange, atol=1e-6)
    T_flange_cam = load_hand_eye(HAND_EYE, "eye-in-hand", "mm").T_cal
    np.testing.assert_allclose(report["T_base_cam"], flange @ T_flange_cam, atol=1e-6)
    assert report["tcp_in_workspace"] is True
    human = cli("status", "--config", str(write_config(tmp_path, ctl.host)))
    assert human.returncode == 0
    assert "READY to pick" in human.stdout


def _dashboard(host: str, *commands: str) -> list[str]:
    with socket.create_connection((host, 29999), timeout=5.0) as sock:
        reader = sock.makefile("r")
        reader.readline()  # banner
        answers = []
        for command in commands:
            sock.sendall(command.encode() + b"\n")
            answers.append(reader.readline().strip())
        return answers


def test_status_leaves_the_controller_as_it_found_it(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    _dashboard(ctl.host, "load /programs/pick.urp")
    before = _dashboard(ctl.host, "programState", "get loaded program", "running")
    assert before[0] == "STOPPED pick.urp"
    status, report = cli_json("status", "--config", str(write_config(tmp_path, ctl.host)))
    assert status == 0, report
    assert (report["program_state"], report["loaded_program"]) == (
        "STOPPED pick.urp",
        "/programs/pick.urp",
    )
    assert _dashboard(ctl.host, "programState", "get loaded program", "running") == before
    assert ctl.snapshot().runtime_state == RuntimeState.STOPPED
    assert ctl.commands == []


def test_status_beside_a_running_session_does_not_disturb_it(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    with URRtdeArm(ctl.host, watchdog_s=TEST_WATCHDOG_S) as arm:
        status, report = cli_json("status", "--config", str(write_config(tmp_path, ctl.host)))
        assert status == 3, report
        assert report["program_state"] == "PLAYING rtde_control"
        assert report["tcp_offset_matches"] is True  # read without the session's program
        assert len(report["problems"]) == 1
        assert "a program is running on the controller" in report["problems"][0]
        # the session's program still runs and still moves the arm
        assert arm.status().runtime_state == RuntimeState.PLAYING
        T_base_tcp = arm.tcp_pose()
        T_base_tcp[2, 3] += 0.01
        arm.move_linear(T_base_tcp, 0.1, 0.5, timeout_s=10.0)
    assert [command["kind"] for command in ctl.commands] == ["moveL"]


def test_status_of_a_controller_without_tcp_offset_output_says_so(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(profile="e-series-5.4", tcp_offset=TCP_OFFSET, instant=True)
    status, report = cli_json("status", "--config", str(write_config(tmp_path, ctl.host)))
    assert status == 3, report
    assert report["controller_version"] == "5.4.3.77771"
    assert report["remote_control"] is True  # no Remote Control before 5.6: nothing to be in
    assert "tcp_offset" not in report
    assert len(report["problems"]) == 1
    assert "does not serve tcp_offset" in report["problems"][0]


def test_status_without_an_answer_exits_4_in_one_line(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    ctl.stop()  # nothing listens at the address any more
    result = cli("status", "--quiet", "--config", str(write_config(tmp_path, ctl.host)))
    assert result.returncode == 4, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert "RTDE port 30004" in result.stderr
    assert "check the address" in result.stderr


def test_status_of_a_host_that_accepts_and_never_answers_exits_4_with_the_same_advice(
    tmp_path: Path, loopback_host: str
) -> None:
    """A hung controller or another device at the address: the connection is taken and nothing
    comes back. Bounded, one line, and the same advice as an address where nothing listens."""
    with socket.create_server((loopback_host, 30004)):
        result = cli("status", "--quiet", "--config", str(write_config(tmp_path, loopback_host)))
    assert result.returncode == 4, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert "RTDE port 30004 (timed out)" in result.stderr
    assert "check the address" in result.stderr


def test_status_of_polyscope_x_reads_rtde_alone(sim_controller: SimFactory, tmp_path: Path) -> None:
    # docs/field-experience.md, "PolyScope X": it has no dashboard server; remote control does
    # not apply there.
    ctl = sim_controller(profile="polyscope-x", tcp_offset=TCP_OFFSET, instant=True)
    status, report = cli_json("status", "--config", str(write_config(tmp_path, ctl.host)))
    assert status == 3, report
    assert report["controller_version"] == "10.7.0.1234"
    assert (report["runtime_state"], report["program_state"]) == ("PLAYING", None)
    assert report["tcp_offset_matches"] is True
    assert len(report["problems"]) == 2, report["problems"]
    assert "PolyScope X has none" in report["problems"][0]
    assert "a program is running" in report["problems"][1]


def test_status_protective_stop_is_not_ready(sim_controller: SimFactory, tmp_path: Path) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    ctl.inject("protective-stop")
    result = cli("status", "--config", str(write_config(tmp_path, ctl.host)))
    assert result.returncode == 3, result.stderr
    assert "NOT READY" in result.stdout
    assert "protective stop" in result.stdout


def test_status_local_control_is_not_ready(sim_controller: SimFactory, tmp_path: Path) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    ctl.set_remote_control(False)
    status, report = cli_json("status", "--config", str(write_config(tmp_path, ctl.host)))
    assert status == 3, report
    assert report["ready"] is False
    assert any("Remote Control" in problem for problem in report["problems"]), report


def test_status_tcp_offset_mismatch_is_not_ready(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=(0.0, 0.0, 0.10, 0.0, 0.0, 0.0), instant=True)
    status, report = cli_json("status", "--config", str(write_config(tmp_path, ctl.host)))
    assert status == 3, report
    assert report["tcp_offset_matches"] is False
    assert report["tcp_offset_difference"]["mm"] == pytest.approx(20.0, abs=1e-3)
    assert len(report["problems"]) == 1
    assert "TCP offset" in report["problems"][0]


# --- plan --plot --------------------------------------------------------------------------------


def test_plan_live_matches_the_pick_dry_run_and_moves_nothing(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_config(tmp_path, ctl.host)
    png = tmp_path / "plan.png"
    before = _dashboard(ctl.host, "programState", "running")
    status, report = cli_json(
        "plan", "--config", str(config), "--xyz", *POINT_CAM_MM, "--plot", str(png)
    )
    assert status == 0, report
    assert ctl.commands == []
    assert _dashboard(ctl.host, "programState", "running") == before  # no program started
    assert not (tmp_path / "picks.jsonl").exists()  # nothing moved, nothing to audit
    assert matplotlib.image.imread(png).shape[:2] == (FIGURE_SIZE_PX[1], FIGURE_SIZE_PX[0])
    np.testing.assert_allclose(
        ur_pose_to_matrix(report["object_pose"])[:3, 3], expected_point_base_m(ctl), atol=1e-9
    )
    pick_status, pick = cli_json(
        "pick", "--config", str(config), "--xyz", *POINT_CAM_MM, "--dry-run"
    )
    assert pick_status == 0, pick
    assert report["targets"] == pick["targets"]


def test_plan_offline_with_a_cloud(tmp_path: Path) -> None:
    cloud = np.full((40, 60, 3), np.nan, dtype=np.float32)
    cloud[10:30, 10:50] = [30.0, -20.0, 380.0]
    np.save(tmp_path / "cloud.npy", cloud)
    # No controller listens on this address: the flange comes from the command line only.
    config = write_config(tmp_path, "127.0.0.254")
    flange_ur = ["-0.4919", "-0.1333", "0.4879", "2.2214", "2.2214", "0"]
    png = tmp_path / "plan.png"
    result = cli(
        "plan",
        "--config",
        str(config),
        "--cloud",
        str(tmp_path / "cloud.npy"),
        "--pixel",
        "20",
        "15",
        "--robot-pose-ur",
        *flange_ur,
        "--plot",
        str(png),
    )
    assert result.returncode == 0, result.stderr
    assert "flange from --robot-pose-ur" in result.stdout
    assert matplotlib.image.imread(png).shape[:2] == (FIGURE_SIZE_PX[1], FIGURE_SIZE_PX[0])


# --- touch-test ---------------------------------------------------------------------------------


def test_touch_test_descends_slowly_to_the_standoff_and_back(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    point = expected_point_base_m(ctl)
    # A gripper in the config is never switched by a touch test.
    gripper = "  gripper:\n    bank: tool\n    index: 0\n    close_value: true\n"
    result = cli(
        "touch-test",
        "--config",
        str(write_config(tmp_path, ctl.host, gripper=gripper)),
        "--xyz",
        *POINT_CAM_MM,
        "--standoff-mm",
        "15",
    )
    assert result.returncode == 0, result.stderr
    p_mm = point * 1000.0
    assert f"[{p_mm[0]:.1f}, {p_mm[1]:.1f}, {p_mm[2]:.1f}] mm" in result.stdout
    moves = [c for c in ctl.commands if c["kind"].startswith("move")]
    assert [m["kind"] for m in moves] == ["moveL"] * 3
    approach, standoff, back = (ur_pose_to_matrix(m["target"]) for m in moves)
    # Tool straight down, 100 mm above, then 15 mm above the point at the grasp speed, then up.
    np.testing.assert_allclose(standoff[:3, 2], [0.0, 0.0, -1.0], atol=1e-9)
    np.testing.assert_allclose(approach[:3, 3], point + np.array([0.0, 0.0, 0.100]), atol=1e-9)
    np.testing.assert_allclose(standoff[:3, 3], point + np.array([0.0, 0.0, 0.015]), atol=1e-9)
    np.testing.assert_allclose(back, approach, atol=1e-12)
    assert moves[1]["speed"] == GRASP_SPEED_MPS
    assert ctl.snapshot().tool_digital_out == 0
    np.testing.assert_allclose(
        ur_pose_to_matrix(list(ctl.snapshot().tcp_pose)), approach, atol=1e-6
    )
    plan, outcome = audit_records(tmp_path)
    assert (plan["event"], outcome["event"], outcome["status"]) == ("plan", "outcome", "picked")
    assert plan["detection"]["source"].startswith("touch-test")
    assert all(check["passed"] for check in plan["checks"])
    np.testing.assert_allclose(ur_pose_to_matrix(plan["targets"]["grasp"]), standoff, atol=1e-9)


def test_touch_test_confirm_waits_for_enter_on_a_terminal(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_config(tmp_path, ctl.host)
    point = expected_point_base_m(ctl)
    args = ("--config", str(config), "--xyz", *POINT_CAM_MM, "--confirm", "--json")
    terminal, terminal_side = pty.openpty()  # a person at a terminal presses Enter
    try:
        os.write(terminal, b"\n")
        result = subprocess.run(
            [*CLI, "touch-test", *args],
            cwd=ROOT,
            stdin=terminal_side,
            capture_output=True,
            text=True,
            timeout=120,
        )
    finally:
        os.close(terminal)
        os.close(terminal_side)
    assert result.returncode == 0, result.stderr
    assert "press Enter to descend" in result.stderr
    assert len([c for c in ctl.commands if c["kind"].startswith("move")]) == 3
    assert audit_records(tmp_path)[-1]["status"] == "picked"
    report = json.loads(result.stdout)  # the prompt never mixes into the JSON
    np.testing.assert_allclose(report["point_base_mm"], point * 1000.0, atol=1e-6)
    assert report["status"] == "done"


def test_touch_test_confirm_without_a_terminal_refuses_before_moving(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_config(tmp_path, ctl.host)
    result = cli(
        "touch-test", "--config", str(config), "--xyz", *POINT_CAM_MM, "--confirm", stdin="\n"
    )
    assert result.returncode == 2, result.stderr
    assert "not a terminal" in result.stderr
    assert ctl.commands == []


def test_touch_test_refuses_a_standoff_beyond_the_approach(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    result = cli(
        "touch-test",
        "--config",
        str(write_config(tmp_path, ctl.host)),
        "--xyz",
        *POINT_CAM_MM,
        "--standoff-mm",
        "100",
    )
    assert result.returncode == 2
    assert "--standoff-mm" in result.stderr
    assert ctl.commands == []
