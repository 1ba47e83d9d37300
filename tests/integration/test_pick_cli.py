"""``handeye-pick pick`` end to end: the CLI in a subprocess, the real ur_rtde, the simulated UR.

Each test checks what the operator and the auditor see (exit status, JSON, audit file) against
what the controller received (its command record), and frames against the controller's own
snapshot, never against our own arithmetic alone.
"""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from handeye_pick.detection import load_detection
from handeye_pick.geometry import invert, transform_point, ur_pose_to_matrix
from handeye_pick.hand_eye.files import HandEyeMode, load_hand_eye
from mocks.ur_controller import SimulatedController
from tests.conftest import TEST_WATCHDOG_S

SimFactory = Callable[..., SimulatedController]
ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "config" / "demo"
TCP_OFFSET = (0.0, 0.0, 0.12, 0.0, 0.0, 0.0)
MOTION_KINDS = {"moveL", "moveJ", "moveL_FK", "moveJ_IK"}
CLI = [sys.executable, "-c", "import sys; from handeye_pick.cli import main; sys.exit(main())"]
# A camera 1.2 m above the base plane looking straight down (eye-to-hand T_base_cam, mm), and
# the same file written the other way round (T_cam_base): read without invert, another camera
# looking straight down from (100, 450, 1200) mm, which every geometric check accepts.
EYE_TO_HAND = "[[0, 1, 0, -450], [1, 0, 0, -100], [0, 0, -1, 1200], [0, 0, 0, 1]]\n"
EYE_TO_HAND_INVERSE = "[[0, 1, 0, 100], [1, 0, 0, 450], [0, 0, -1, 1200], [0, 0, 0, 1]]\n"
TAPED_CAMERA = "  camera_position_mm: [-430, -120, 1180]\n"  # 35 mm off the optical origin


def write_config(tmp_path: Path, host: str, **overrides: str) -> Path:
    """A cell config for the simulated controller; ``overrides`` replace whole top-level
    sections (YAML text) or add robot keys (``robot_extra``)."""
    sections = {
        "hand_eye": f"  mode: eye-in-hand\n  file: {DEMO / 'hand_eye.yaml'}\n  units: mm\n",
        "grasp": "  approach_mm: 100\n  retreat_mm: 100\n",
        "motion": "  speed_mps: 0.25\n  accel_mps2: 1.2\n  grasp_speed_mps: 0.1\n",
        "workspace": "  min_mm: [-800, -800, 20]\n  max_mm: [800, 800, 700]\n  max_tilt_deg: 30\n",
        "audit": "  file: picks.jsonl\n",
    }
    sections.update({k: v for k, v in overrides.items() if k not in ("robot_extra", "watchdog_s")})
    text = f"robot:\n  host: {host}\n  tcp_offset: {list(TCP_OFFSET)}\n"
    text += f"  watchdog_s: {overrides.get('watchdog_s', TEST_WATCHDOG_S)}\n"
    text += overrides.get("robot_extra", "")
    text += "".join(f"{name}:\n{body}" for name, body in sections.items())
    path = tmp_path / "cell.yaml"
    path.write_text(text)
    return path


def run_pick(config: Path, *args: str, timeout_s: float = 60.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*CLI, "pick", "--config", str(config), *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=timeout_s,
        check=False,
    )


def run_json(config: Path, *args: str) -> tuple[int, dict[str, Any]]:
    result = run_pick(config, "--json", *args)
    return result.returncode, json.loads(result.stdout)


def audit_records(tmp_path: Path) -> list[dict[str, Any]]:
    path = tmp_path / "picks.jsonl"
    return [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []


def motion_commands(ctl: SimulatedController) -> list[dict[str, Any]]:
    return [c for c in ctl.commands if c["kind"] in MOTION_KINDS]


def assert_pose(actual: Any, expected: Any, atol: float = 1e-6) -> None:
    """UR vectors compared as matrices (rotation vectors near pi may flip sign)."""
    np.testing.assert_allclose(
        ur_pose_to_matrix(list(actual)), ur_pose_to_matrix(list(expected)), atol=atol
    )


# --- picks that run to the end ------------------------------------------------------------------


def test_eye_in_hand_pick_with_tcp_offset(sim_controller: SimFactory, tmp_path: Path) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    flange_before = ctl.snapshot().flange_pose
    status, report = run_json(
        write_config(tmp_path, ctl.host), "--detection", str(DEMO / "detection.yaml")
    )
    assert status == 0, report
    assert report["status"] == "picked"
    assert_pose(report["flange_pose"], flange_before)
    # The chain from the controller's own flange, not from anything our code read.
    T_flange_cam = load_hand_eye(DEMO / "hand_eye.yaml", "eye-in-hand", "mm").T_cal
    T_cam_obj = load_detection(DEMO / "detection.yaml").T_cam_obj
    T_grasp = ur_pose_to_matrix(list(flange_before)) @ T_flange_cam @ T_cam_obj
    np.testing.assert_allclose(ur_pose_to_matrix(report["targets"]["grasp"]), T_grasp, atol=1e-7)
    moves = motion_commands(ctl)
    assert [m["kind"] for m in moves] == ["moveL"] * 3
    for move, step in zip(moves, ("approach", "grasp", "retreat"), strict=True):
        assert_pose(move["target"], report["targets"][step])
    assert [m["speed"] for m in moves] == [0.25, 0.1, 0.25]
    assert_pose(ctl.snapshot().tcp_pose, report["targets"]["retreat"])
    plan, outcome = audit_records(tmp_path)
    assert (plan["event"], outcome["event"], outcome["status"]) == ("plan", "outcome", "picked")
    assert plan["pick_id"] == outcome["pick_id"] == report["pick_id"]
    assert plan["targets"] == report["targets"]
    assert outcome["errors"]["grasp"]["position_mm"] < 0.01


@pytest.mark.parametrize(
    "told_apart", [TAPED_CAMERA, "  acknowledge: [camera-position-measured]\n"]
)
def test_eye_to_hand_position_only_pick(
    sim_controller: SimFactory, tmp_path: Path, told_apart: str
) -> None:
    # A straight-down camera's file is told from its inverse by the taped camera position, or
    # the cell acknowledges that it cannot be, and the audit says so.
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    (tmp_path / "eth.yaml").write_text(EYE_TO_HAND)
    hand_eye = f"  mode: eye-to-hand\n  file: {tmp_path / 'eth.yaml'}\n  units: mm\n{told_apart}"
    tcp_before = ur_pose_to_matrix(list(ctl.snapshot().tcp_pose))
    status, report = run_json(
        write_config(tmp_path, ctl.host, hand_eye=hand_eye), "--xyz", "50", "-20", "1100"
    )
    assert status == 0, report
    grasp = ur_pose_to_matrix(report["targets"]["grasp"])
    # camera at (-450, -100, 1200) mm, x/y swapped, z down: the point is 100 mm above the base
    np.testing.assert_allclose(grasp[:3, 3], [-0.470, -0.050, 0.100], atol=1e-9)
    np.testing.assert_allclose(grasp[:3, 2], [0.0, 0.0, -1.0], atol=1e-12)  # tool straight down
    np.testing.assert_allclose(grasp[:3, 0], tcp_before[:3, 0], atol=1e-9)  # current yaw kept
    assert_pose(ctl.snapshot().tcp_pose, report["targets"]["retreat"])
    plan = audit_records(tmp_path)[0]
    plausible = [c for c in plan["checks"] if c["name"].startswith("plausible")]
    if told_apart == TAPED_CAMERA:
        assert plausible == []
    else:
        (acknowledged,) = plausible
        assert acknowledged["name"] == "plausible camera-position-measured"
        assert acknowledged["passed"] is True
        assert "cannot be told from its inverse" in acknowledged["detail"]
        assert acknowledged["detail"].endswith("(acknowledged in hand_eye.acknowledge)")


def test_pixel_in_a_cloud_and_dry_run_moves_nothing(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    cloud = np.full((4, 6, 3), np.nan, dtype=np.float32)
    cloud[2, 5] = [35.0, -20.0, 384.0]  # row 2, column 5
    np.save(tmp_path / "cloud.npy", cloud)
    config = write_config(tmp_path, ctl.host)
    status, report = run_json(
        config, "--cloud", str(tmp_path / "cloud.npy"), "--pixel", "5", "2", "--dry-run"
    )
    assert status == 0, report
    assert report["status"] == "dry-run"
    assert ctl.commands == []
    plan, outcome = audit_records(tmp_path)
    assert plan["dry_run"] is True
    assert outcome["status"] == "dry-run"
    _, from_xyz = run_json(config, "--xyz", "35", "-20", "384", "--dry-run")
    assert report["targets"] == from_xyz["targets"]


def test_progress_lines_and_summary_for_a_person(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_config(tmp_path, ctl.host)
    quiet = run_pick(config, "--xyz", "35", "-20", "384", "--dry-run", "--quiet")
    assert quiet.returncode == 0
    assert quiet.stderr == ""
    quiet_before = subprocess.run(  # the global flags also work before the command name
        [
            *CLI,
            "--quiet",
            "pick",
            "--config",
            str(config),
            "--xyz",
            "35",
            "-20",
            "384",
            "--dry-run",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert quiet_before.returncode == 0
    assert quiet_before.stderr == ""
    result = run_pick(
        config,
        "--detection",
        str(DEMO / "detection.yaml"),
        "--log-file",
        str(tmp_path / "debug.log"),
    )
    assert result.returncode == 0, result.stderr
    lines = result.stderr.splitlines()
    for expected in ("connecting to", "planned:", "approach", "grasp", "retreat"):
        assert any(line.startswith(expected) for line in lines), (expected, lines)
    assert any(line.startswith("retreat done in") for line in lines)
    assert "pick picked" in result.stdout
    log = (tmp_path / "debug.log").read_text()
    # Every controller call with its duration: the TCP offset, the steady flange pose, each
    # pre-flight query, the readiness bits and the moves, and the session's dashboard questions.
    for call in (
        "tcp_offset()",
        "fresh_sample()",
        "is_pose_within_safety_limits(",
        "has_ik_solution(",
        "move_l_async(",
    ):
        assert re.search(rf"{re.escape(call)}.* -> ok .* in \d+\.\d\d ms", log), call
    for question in ("'PolyscopeVersion'", "'is in remote control'"):
        assert re.search(rf"dashboard {question} -> .* in \d+\.\d\d ms", log), question


# --- refusals: nothing moves ----------------------------------------------------------------------


@pytest.mark.parametrize(
    ("overrides", "args", "failed"),
    [
        (  # the grasp is 50 mm above the base plane, the box starts at 100 mm
            {
                "workspace": "  min_mm: [-800, -800, 100]\n  max_mm: [800, 800, 700]\n"
                "  max_tilt_deg: 30\n"
            },
            ("--detection", str(DEMO / "detection.yaml")),
            {("workspace", "grasp")},
        ),
        (  # the demo detection tilts the tool 5 degrees
            {
                "workspace": "  min_mm: [-800, -800, 20]\n  max_mm: [800, 800, 700]\n"
                "  max_tilt_deg: 2\n"
            },
            ("--detection", str(DEMO / "detection.yaml")),
            {("tilt", step) for step in ("approach", "grasp", "retreat")},
        ),
        (  # 1.5 m below the camera is out of a UR5e's reach; the box allows it
            {
                "workspace": "  min_mm: [-3000, -3000, -3000]\n  max_mm: [3000, 3000, 3000]\n"
                "  max_tilt_deg: 30\n"
            },
            ("--xyz", "0", "0", "1500"),
            {
                (check, step)
                for check in ("safety_limits", "ik")
                for step in ("approach", "grasp", "retreat")
            },
        ),
    ],
    ids=["workspace", "tilt", "controller-limits"],
)
def test_preflight_refusal_moves_nothing(
    sim_controller: SimFactory,
    tmp_path: Path,
    overrides: dict[str, str],
    args: tuple[str, ...],
    failed: set[tuple[str, str]],
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    status, report = run_json(write_config(tmp_path, ctl.host, **overrides), *args)
    assert status == 3, report
    assert report["status"] == "refused"
    assert {(c["name"], c["target"]) for c in report["checks"] if not c["passed"]} == failed
    assert "targets" in report
    assert ctl.commands == []
    (outcome,) = audit_records(tmp_path)
    assert outcome["status"] == "refused"


@pytest.mark.parametrize(
    ("controller", "prepare", "reason"),
    [
        ({"tcp_offset": (0.0, 0.0, 0.10, 0.0, 0.0, 0.0)}, None, "TCP offset"),
        ({"tcp_offset": TCP_OFFSET, "remote_control": False}, None, "Remote Control"),
        ({"tcp_offset": TCP_OFFSET}, "protective-stop", "protective stop"),
        ({"tcp_offset": TCP_OFFSET}, "emergency-stop", "emergency stop"),
    ],
    ids=["tcp-offset", "remote-control", "protective-stop", "emergency-stop"],
)
def test_unready_cell_is_refused(
    sim_controller: SimFactory,
    tmp_path: Path,
    controller: dict[str, Any],
    prepare: str | None,
    reason: str,
) -> None:
    ctl = sim_controller(instant=True, **controller)
    if prepare is not None:
        ctl.inject(prepare)
    result = run_pick(write_config(tmp_path, ctl.host), "--xyz", "35", "-20", "384")
    assert result.returncode == 3, result.stderr
    assert reason in result.stderr
    assert motion_commands(ctl) == []


# --- faults during the pick ----------------------------------------------------------------------


@pytest.mark.parametrize(
    ("fault", "error_type"),
    [
        ("protective-stop", "RobotFault"),
        ("emergency-stop", "RobotFault"),
        ("safeguard-stop", "RobotFault"),
        ("stop-program", "RobotFault"),
        ("drop-connection", "RobotConnectionError"),
        ("stall:1.5", "RobotConnectionError"),
    ],
)
def test_fault_during_the_grasp_move(
    sim_controller: SimFactory, tmp_path: Path, fault: str, error_type: str
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, speed_factor=4.0, inject=(f"{fault}@move:2:0.5",))
    status, report = run_json(
        write_config(tmp_path, ctl.host), "--detection", str(DEMO / "detection.yaml")
    )
    assert status == 4, report
    assert report["status"] == "fault"
    assert report["error_type"] == error_type
    plan, outcome = audit_records(tmp_path)
    assert plan["event"] == "plan"
    assert outcome["status"] == "fault"
    assert outcome["step"] == "grasp"
    assert outcome["error"]["type"] == error_type
    assert set(outcome["reached"]) == {"approach"}
    kinds = [c["kind"] for c in ctl.commands]
    assert kinds[:2] == ["moveL", "moveL"]
    assert set(kinds[2:]) <= {"stopL"}  # after the fault: stops only, never a new motion
    assert not ctl.snapshot().moving


def test_controller_that_stops_answering_ends_the_pick(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    # Each command is answered 8 s late from the approach on. The ur_rtde process cannot feed
    # the watchdog while it waits, so the controller stops the program after the watchdog
    # window (1 s here), long before the adapter's 6 s call limit: the pick ends either way.
    ctl = sim_controller(tcp_offset=TCP_OFFSET, speed_factor=4.0, inject=("slow:8@move:1:0.5",))
    status, report = run_json(
        write_config(tmp_path, ctl.host), "--detection", str(DEMO / "detection.yaml")
    )
    assert status == 4, report
    assert report["error_type"] in ("RobotFault", "RobotConnectionError")
    assert len(motion_commands(ctl)) <= 2
    assert audit_records(tmp_path)[-1]["status"] == "fault"
    assert not ctl.snapshot().moving


def test_remote_control_switched_off_mid_pick_aborts_it_as_a_fault(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    # Only the dashboard's answer changes and the running move ends; remote control is checked
    # again before every move, so the retreat is never sent. The arm has moved and stands at
    # the grasp: not "refused, nothing moved" (exit 3) but a fault of its own (exit 4, aborted).
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET, speed_factor=4.0, inject=("remote-control-off@move:2:0.5",)
    )
    status, report = run_json(
        write_config(tmp_path, ctl.host), "--detection", str(DEMO / "detection.yaml")
    )
    assert status == 4, report
    assert report["status"] == "aborted"
    assert report["error_type"] == "SequenceAborted"
    assert "local control" in str(report["error"])
    assert "stands at 'grasp'" in str(report["error"])
    outcome = audit_records(tmp_path)[-1]
    assert outcome["status"] == "aborted"
    assert outcome["step"] == "retreat"
    assert set(outcome["reached"]) == {"approach", "grasp"}
    assert "local control" in outcome["error"]["message"]
    assert outcome["stop"] == "stopL sent"
    assert len(motion_commands(ctl)) == 2
    assert not ctl.snapshot().moving


def test_ctrl_c_during_a_slow_move(sim_controller: SimFactory, tmp_path: Path) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, speed_factor=0.2)
    pick = subprocess.Popen(
        [
            *CLI,
            "pick",
            "--config",
            str(write_config(tmp_path, ctl.host)),
            "--detection",
            str(DEMO / "detection.yaml"),
        ],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert pick.stderr is not None
        for line in pick.stderr:
            if line.startswith("approach"):  # the first moveL is on its way
                break
        deadline = time.monotonic() + 20.0
        while not ctl.snapshot().moving and time.monotonic() < deadline:
            time.sleep(0.01)
        pick.send_signal(signal.SIGINT)
        _, rest = pick.communicate(timeout=30)
    finally:
        if pick.poll() is None:
            pick.kill()
    assert pick.returncode == 130, rest
    assert [c["kind"] for c in ctl.commands] == ["moveL", "stopL"], rest
    assert not ctl.snapshot().moving
    _, outcome = audit_records(tmp_path)
    assert outcome["status"] == "interrupted"
    assert outcome["step"] == "approach"


# --- bad input: exit 2, the controller is never contacted ----------------------------------------


@pytest.mark.parametrize(
    ("config_text", "detection_text", "args", "message"),
    [
        ("speed", None, (), "motion.speed_mps"),
        ("unknown", None, (), "colour"),
        (None, "position_mm: [1, 2]\n", (), "position_mm"),
        (
            None,
            "position_mm: [35, -20, 384]\norientation: {rotvec_deg: [0, 0, 1]}\n",
            (),
            "rotvec_deg",
        ),
        (None, None, ("--xyz", "1", "2", "3"), "either --detection"),
        (None, None, ("--pixel", "1", "2"), "--cloud"),
    ],
    ids=[
        "speed-cap",
        "unknown-key",
        "short-position",
        "unknown-orientation",
        "two-inputs",
        "pixel-without-cloud",
    ],
)
def test_bad_input_exits_2_without_contacting_the_robot(
    tmp_path: Path,
    loopback_host: str,
    config_text: str | None,
    detection_text: str | None,
    args: tuple[str, ...],
    message: str,
) -> None:
    overrides = {
        "speed": {"motion": "  speed_mps: 5\n  accel_mps2: 1.2\n  grasp_speed_mps: 0.1\n"},
        "unknown": {"audit": "  file: picks.jsonl\n  colour: blue\n"},
        None: {},
    }[config_text]
    config = write_config(tmp_path, loopback_host, **overrides)
    detection = tmp_path / "detection.yaml"
    detection.write_text(detection_text or "position_mm: [35, -20, 384]\n")
    detection_args = () if "--pixel" in args else ("--detection", str(detection))
    result = run_pick(config, *detection_args, *args, timeout_s=30)
    assert result.returncode == 2, result.stderr
    assert message in result.stderr
    assert result.stderr.count("\n") == 1  # one line, no traceback
    assert not (tmp_path / "picks.jsonl").exists()


def test_a_cb3_controller_picks_without_remote_control(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    # PolyScope 3 has no Remote Control mode and answers the dashboard's question with an error:
    # the readiness check does not apply there, every other check does.
    ctl = sim_controller(profile="cb3", model="ur5", tcp_offset=TCP_OFFSET, instant=True)
    T_base_flange = ur_pose_to_matrix(ctl.snapshot().flange_pose)
    T_flange_cam = load_hand_eye(DEMO / "hand_eye.yaml", HandEyeMode.EYE_IN_HAND, "mm").T_cal
    object_base_m = T_base_flange[:3, 3] + np.array([0.03, 0.02, -0.40])
    p_cam_mm = transform_point(invert(T_base_flange @ T_flange_cam), object_base_m) * 1000.0
    status, report = run_json(
        write_config(tmp_path, ctl.host), "--xyz", *(f"{v:.6f}" for v in p_cam_mm)
    )
    assert status == 0, report
    assert len(motion_commands(ctl)) == 3


def test_a_controller_without_a_dashboard_is_refused_with_the_reason(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(profile="polyscope-x", tcp_offset=TCP_OFFSET, instant=True)
    status, report = run_json(
        write_config(tmp_path, ctl.host), "--detection", str(DEMO / "detection.yaml")
    )
    assert status == 4, report
    assert "PolyScope X" in report["error"]
    assert motion_commands(ctl) == []


@pytest.mark.parametrize(
    ("hand_eye", "mistake"),
    [
        (
            f"  mode: eye-in-hand\n  file: {DEMO / 'hand_eye.yaml'}\n  units: mm\n  invert: true\n",
            "invert",
        ),
        (f"  mode: eye-to-hand\n  file: {DEMO / 'hand_eye.yaml'}\n  units: mm\n", "eye-in-hand"),
        (
            f"  mode: eye-to-hand\n  file: eth_inverse.yaml\n  units: mm\n{TAPED_CAMERA}",
            "the inverse file puts it 35 mm from there: the calibration looks inverted "
            "(hand_eye.invert: true)",
        ),
        (
            "  mode: eye-to-hand\n  file: eth_inverse.yaml\n  units: mm\n",
            "cannot be told from its inverse: it puts the camera at [100, 450, 1200] mm",
        ),
    ],
)
def test_an_inverted_or_swapped_calibration_is_refused_before_any_motion(
    sim_controller: SimFactory, tmp_path: Path, hand_eye: str, mistake: str
) -> None:
    # Issue 11: the inverted demo file ran to an object 123 mm off and exited 0; a straight-down
    # fixed camera's inverted file ran 778 mm off.
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    (tmp_path / "eth.yaml").write_text(EYE_TO_HAND)
    (tmp_path / "eth_inverse.yaml").write_text(EYE_TO_HAND_INVERSE)
    status, report = run_json(
        write_config(tmp_path, ctl.host, hand_eye=hand_eye),
        "--detection",
        str(DEMO / "detection.yaml"),
    )
    assert status == 3, report
    assert "plausible" in report["error"]
    assert mistake in report["error"]
    assert motion_commands(ctl) == []
    assert audit_records(tmp_path)[-1]["status"] == "refused"


def test_an_audit_file_that_cannot_be_written_is_found_before_connecting(
    tmp_path: Path, loopback_host: str
) -> None:
    # audit.file names a folder: exit 2 and one line, and nothing listens at the address, so
    # a connection attempt would have been a different error.
    (tmp_path / "picks.jsonl").mkdir()
    result = run_pick(write_config(tmp_path, loopback_host), "--xyz", "35", "-20", "384")
    assert result.returncode == 2, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert "picks.jsonl" in result.stderr


def test_a_pick_killed_after_its_plan_is_closed_as_abandoned_at_the_next_start(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_config(tmp_path, ctl.host)
    plan = {
        "timestamp": "2026-11-29T10:00:00+00:00",
        "pick_id": "killed",
        "event": "plan",
        "host": ctl.host,
    }
    (tmp_path / "picks.jsonl").write_text(json.dumps(plan) + "\n" + '{"timestamp": "2026-11-2')
    result = run_pick(config, "--detection", str(DEMO / "detection.yaml"))
    assert result.returncode == 0, result.stderr
    assert "abandoned" in result.stderr
    records = [
        json.loads(line)
        for line in (tmp_path / "picks.jsonl").read_text().splitlines()
        if line.startswith("{") and line.endswith("}")
    ]
    closed = [r for r in records if r.get("pick_id") == "killed" and r["event"] == "outcome"]
    assert [r["status"] for r in closed] == ["abandoned"]
    assert records[-1]["status"] == "picked"


def test_a_move_the_controller_refuses_is_a_fault_not_a_success(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    # ur_rtde answers the refused moveL with False while every status flag reads normal: the
    # pick must end there (a mutation treating False as success survived the suite before).
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    ctl.inject("refuse-move")
    status, report = run_json(
        write_config(tmp_path, ctl.host), "--detection", str(DEMO / "detection.yaml")
    )
    assert status == 4, report
    assert "refused" in report["error"]
    outcome = audit_records(tmp_path)[-1]
    assert (outcome["status"], outcome["step"]) == ("fault", "approach")
    assert [c["kind"] for c in motion_commands(ctl) if not c.get("refused")] == []


def test_a_link_frozen_mid_move_ends_the_pick_and_the_arm_does_not_finish_the_move(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    # Issue 11: the controller stalls 3 s mid-approach, then answers again. The pick ends with
    # exit 4; the stop (the dashboard's, retried until confirmed, or the starved watchdog's)
    # leaves the arm short of the approach target instead of finishing the move on its own.
    ctl = sim_controller(tcp_offset=TCP_OFFSET, speed_factor=0.5, inject=("stall:3@move:1:0.3",))
    status, report = run_json(
        write_config(tmp_path, ctl.host), "--detection", str(DEMO / "detection.yaml")
    )
    assert status == 4, report
    time.sleep(0.5)
    snapshot = ctl.snapshot()
    assert not snapshot.moving
    approach = motion_commands(ctl)[0]["target"]
    assert np.linalg.norm(np.subtract(snapshot.tcp_pose[:3], approach[:3])) > 0.005
