"""The cell's pick sequence against a scripted RobotArm: order, chain, refusals, audit on every
ending, candidates, place, named poses, capture latching, halt and resume.

The fake stands in for the RobotArm port (our own Protocol), not for ur_rtde; the real adapter
is covered end to end in tests/integration against the simulated controller.
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
import uuid
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest

from handeye_pick import progress as progress_module
from handeye_pick.cell.plan import NoFeasibleCandidate
from handeye_pick.cell.sequence import move_timeout_s
from handeye_pick.cell.session import Cell, PickResult
from handeye_pick.config.load import load_config
from handeye_pick.config.schema import CellConfig
from handeye_pick.detection import Detection, detection_from_point_mm
from handeye_pick.errors import (
    CellHalted,
    InputError,
    RobotFault,
    SafetyRefusal,
    SequenceAborted,
    ending,
)
from handeye_pick.geometry import (
    Transform,
    make_transform,
    rotation_from_euler,
    ur_pose_to_matrix,
)
from handeye_pick.hand_eye.files import HandEyeCalibration, load_hand_eye
from handeye_pick.progress import Progress
from handeye_pick.robot.port import OutputBank, ProgressCallback, RobotStatus, Waypoint
from handeye_pick.safety import PreflightRefusal

ROOT = Path(__file__).resolve().parents[2]
DEMO_HAND_EYE = ROOT / "config" / "demo" / "hand_eye.yaml"
T_FLANGE_TCP = ur_pose_to_matrix([0.0, 0.0, 0.12, 0.0, 0.0, 0.0])
# Flange 0.5 m above the base plane, tool down (pi about base x), turned 30 deg about base z.
T_BASE_FLANGE = make_transform(
    rotation_from_euler([180.0, 0.0, 30.0], "xyz", "deg"), [-0.45, -0.10, 0.50]
)
READY = RobotStatus(
    "5.15.0",
    robot_mode=7,
    safety_mode=1,
    runtime_state=2,
    remote_control=True,
    protective_stopped=False,
    emergency_stopped=False,
)


class ScriptedArm:
    """A RobotArm that reaches every target exactly and records what it was asked."""

    def __init__(self, audit_path: Path) -> None:
        self.audit_path = audit_path
        self.status_value = READY
        self.T_flange_tcp = T_FLANGE_TCP
        self.T_base_flange = T_BASE_FLANGE.copy()
        self.within_limits = True
        self.refuse_below_z_m: float | None = None  # safety limits refuse TCP targets below
        self.fail_on_move: int | None = None  # 1-based index of the move that fails
        self.fail_on_waypoint: int | None = None  # 0-based waypoint a path fails heading for
        self.failure: BaseException = RobotFault("protective stop", safety_mode=3, runtime_state=2)
        self.calls: list[tuple[str, object]] = []
        self.audit_lines_at_first_move: int | None = None

    def status(self) -> RobotStatus:
        return self.status_value

    def remote_control(self) -> bool:
        return self.status_value.remote_control

    def tcp_offset(self) -> Transform:
        return self.T_flange_tcp

    def tcp_pose(self) -> Transform:
        return self.T_base_flange @ self.T_flange_tcp

    def flange_pose(self) -> Transform:
        return self.T_base_flange.copy()

    def steady_flange_pose(self, timeout_s: float) -> Transform:
        self.calls.append(("steady", timeout_s))
        return self.T_base_flange.copy()

    def joint_positions(self) -> tuple[float, ...]:
        return (0.0, -1.57, 1.57, -1.57, -1.57, 0.0)

    def joints_within_safety_limits(self, q_rad: object) -> bool:
        return self.within_limits

    def is_pose_within_safety_limits(self, T_base_tcp: Transform) -> bool:
        self.calls.append(("ask", T_base_tcp.copy()))
        if self.refuse_below_z_m is not None and T_base_tcp[2, 3] < self.refuse_below_z_m:
            return False
        return self.within_limits

    def has_ik_solution(self, T_base_tcp: Transform) -> bool:
        return True

    def path_start_s(self) -> float | None:
        return 0.0  # a scripted path starts at once: corners pay wherever they save time

    def measure_path_start(self) -> float:
        return 0.0

    def move_linear(
        self,
        T_base_tcp: Transform,
        speed_mps: float,
        accel_mps2: float,
        timeout_s: float,
        on_progress: ProgressCallback | None = None,
    ) -> Transform:
        moves = [c for c in self.calls if c[0] == "move"]
        if not moves:
            self.audit_lines_at_first_move = len(_records(self.audit_path))
        self.calls.append(("move", (T_base_tcp.copy(), speed_mps, accel_mps2, timeout_s)))
        if self.fail_on_move == len(moves) + 1:
            raise self.failure
        return T_base_tcp.copy()

    def move_path(
        self,
        waypoints: Sequence[Waypoint],
        timeout_s: float,
        on_progress: ProgressCallback | None = None,
    ) -> Transform:
        """Heads for each waypoint in turn (progress k/n .. (k+1)/n, as the port says), failing
        on the way to waypoint ``fail_on_waypoint`` (0-based) when that is set."""
        self.calls.append(("path", (list(waypoints), timeout_s)))
        for index in range(len(waypoints)):
            if on_progress is not None:
                on_progress((index + 0.5) / len(waypoints))
            if self.fail_on_waypoint == index:
                raise self.failure
        return waypoints[-1].T_base_tcp.copy()

    def move_joints(
        self,
        q_rad: object,
        speed_rps: float,
        accel_rps2: float,
        timeout_s: float,
        on_progress: ProgressCallback | None = None,
    ) -> Transform:
        self.calls.append(("movej", (q_rad, speed_rps, accel_rps2)))
        return self.tcp_pose()

    def stop_linear(self, decel_mps2: float) -> None:
        self.calls.append(("stop", decel_mps2))

    def set_digital_output(self, bank: OutputBank, index: int, value: bool) -> None:
        self.calls.append(("output", (bank, index, value)))

    def close(self) -> None:
        self.calls.append(("close", None))

    def moves(self) -> list[tuple[Transform, float, float, float]]:
        return [c[1] for c in self.calls if c[0] == "move"]  # type: ignore[misc]

    def paths(self) -> list[list[Waypoint]]:
        return [c[1][0] for c in self.calls if c[0] == "path"]  # type: ignore[index]


def _records(path: Path) -> list[dict[str, object]]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines()]


def _config(
    tmp_path: Path, mode: str = "eye-in-hand", gripper: str = "", extra: str = ""
) -> CellConfig:
    # A host of its own per cell: a ScriptedArm connects nowhere, and the robot's session lock
    # (cell/lock.py) must not meet another test's cell, in this run or a parallel one.
    text = f"""
robot:
  host: scripted-{uuid.uuid4().hex}
  tcp_offset: [0, 0, 0.12, 0, 0, 0]
{gripper}
hand_eye:
  mode: {mode}
  file: {DEMO_HAND_EYE if mode == "eye-in-hand" else tmp_path / "eth.yaml"}
  units: mm
  {"camera_position_mm: [-400, 0, 1000]" if mode == "eye-to-hand" else ""}
grasp:
  approach_mm: 100
  retreat_mm: 80
motion:
  speed_mps: 0.25
  accel_mps2: 1.2
  grasp_speed_mps: 0.05
workspace:
  min_mm: [-800, -800, 0]
  max_mm: [800, 800, 800]
  max_tilt_deg: 30
audit:
  file: picks.jsonl
{extra}
"""
    if mode == "eye-to-hand":
        # A camera 1 m above the base plane looking straight down.
        (tmp_path / "eth.yaml").write_text(
            "[[1, 0, 0, -400], [0, -1, 0, 0], [0, 0, -1, 1000], [0, 0, 0, 1]]\n"
        )
    path = tmp_path / "cell.yaml"
    path.write_text(text)
    return load_config(path)


def _calibration(config: CellConfig) -> HandEyeCalibration:
    hand_eye = config.hand_eye
    return load_hand_eye(hand_eye.file, hand_eye.mode, hand_eye.units, hand_eye.invert)


def _detection() -> Detection:
    # 380 mm in front of the camera, turned 0.3 rad about the viewing axis.
    T = make_transform(rotation_from_euler([0.0, 0.0, 0.3], "xyz", "rad"), [0.03, -0.02, 0.38])
    return Detection(T, position_only=False, source="test")


def _cell(config: CellConfig, arm: ScriptedArm) -> Cell:
    cell = Cell(config, connect=lambda _config: arm)
    cell.connect()
    return cell


def _run(
    tmp_path: Path,
    arm: ScriptedArm,
    config: CellConfig,
    detection: Detection,
    dry_run: bool = False,
) -> tuple[PickResult, list[dict[str, object]]]:
    result = _cell(config, arm).pick(detection, dry_run=dry_run)
    return result, _records(config.audit.file)


def test_eye_in_hand_grasp_is_flange_calibration_detection_chain(tmp_path: Path) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    detection = _detection()
    _run(tmp_path, arm, config, detection)
    T_flange_cam = _calibration(config).T_cal
    expected_grasp = T_BASE_FLANGE @ T_flange_cam @ detection.T_cam_obj
    (approach, v1, a1, _), (grasp, v2, _, _), (retreat, v3, _, _) = arm.moves()
    np.testing.assert_allclose(grasp, expected_grasp, atol=1e-12)
    # approach and retreat back off along the grasp's own tool z axis
    np.testing.assert_allclose(approach[:3, 3], grasp[:3, 3] - 0.100 * grasp[:3, 2], atol=1e-12)
    np.testing.assert_allclose(retreat[:3, 3], grasp[:3, 3] - 0.080 * grasp[:3, 2], atol=1e-12)
    assert (v1, v2, v3, a1) == (0.25, 0.05, 0.25, 1.2)


def test_eye_to_hand_ignores_the_flange(tmp_path: Path) -> None:
    config = _config(tmp_path, mode="eye-to-hand")
    arm = ScriptedArm(config.audit.file)
    detection = detection_from_point_mm([100.0, 50.0, 900.0], "test")
    _run(tmp_path, arm, config, detection)
    grasp = arm.moves()[1][0]
    # camera at [-400, 0, 1000] mm looking down: x stays, y and z flip
    np.testing.assert_allclose(grasp[:3, 3], [-0.300, -0.050, 0.100], atol=1e-12)
    assert abs(grasp[2, 2] + 1.0) < 1e-12  # position only: tool straight down


def test_plan_is_on_disk_before_the_first_move_then_outcome(tmp_path: Path) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    _, records = _run(tmp_path, arm, config, _detection())
    assert arm.audit_lines_at_first_move == 1
    plan, outcome = records
    assert plan["event"] == "plan"
    assert outcome["event"] == "outcome"
    assert plan["pick_id"] == outcome["pick_id"]
    assert len(plan["checks"]) == 4 + 3 * 4  # type: ignore[arg-type]
    assert plan["calibration"]["sha256"] == _calibration(config).sha256  # type: ignore[index]
    assert plan["flange_pose_source"] == "live"
    assert ("steady", 2.0) in arm.calls  # a live flange pose only while the arm is at rest
    assert outcome["status"] == "picked"
    errors = outcome["errors"]
    assert isinstance(errors, dict)
    assert set(errors) == {"approach", "grasp", "retreat"}
    assert errors["grasp"] == {"position_mm": 0.0, "rotation_deg": 0.0}


def test_dry_run_moves_nothing_and_is_audited(tmp_path: Path) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    _, records = _run(tmp_path, arm, config, _detection(), dry_run=True)
    assert arm.moves() == []
    assert [r["status"] for r in records[1:]] == ["dry-run"]
    assert records[0]["dry_run"] is True


@pytest.mark.parametrize(
    ("change", "reason"),
    [
        ({"remote_control": False}, "Remote Control"),
        ({"protective_stopped": True, "safety_mode": 3}, "protective stop"),
        ({"emergency_stopped": True, "safety_mode": 7}, "emergency stop"),
        ({"runtime_state": 1}, "program is not running"),
    ],
)
def test_unready_cell_is_refused_before_reading_the_plan(
    tmp_path: Path, change: dict[str, object], reason: str
) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    arm.status_value = RobotStatus(**{**vars(READY), **change})  # type: ignore[arg-type]
    with pytest.raises(SafetyRefusal, match=reason):
        _run(tmp_path, arm, config, _detection())
    assert arm.moves() == []
    (outcome,) = _records(config.audit.file)
    assert outcome["status"] == "refused"


def test_tcp_offset_differing_from_config_is_refused(tmp_path: Path) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    arm.T_flange_tcp = ur_pose_to_matrix([0.0, 0.0, 0.10, 0.0, 0.0, 0.0])
    with pytest.raises(SafetyRefusal, match="TCP offset"):
        _run(tmp_path, arm, config, _detection())
    assert arm.moves() == []


def test_preflight_refusal_moves_nothing_and_records_the_checks(tmp_path: Path) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    arm.within_limits = False
    with pytest.raises(PreflightRefusal) as caught:
        _run(tmp_path, arm, config, _detection())
    assert arm.moves() == []
    failed = {(r.name, r.target) for r in caught.value.results if not r.passed}
    assert failed == {("safety_limits", t) for t in ("approach", "grasp", "retreat")}
    (outcome,) = _records(config.audit.file)
    assert outcome["status"] == "refused"
    checks = outcome["error"]["checks"]  # type: ignore[index]
    audited = {(c["name"], c["target"]) for c in checks if not c["passed"]}
    assert audited == failed


def test_fault_during_grasp_records_reached_steps_and_controller_state(tmp_path: Path) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    arm.fail_on_move = 2
    with pytest.raises(RobotFault):
        _run(tmp_path, arm, config, _detection())
    assert len(arm.moves()) == 2  # no retreat after the fault
    _plan, outcome = _records(config.audit.file)
    assert outcome["status"] == "fault"
    assert outcome["step"] == "grasp"
    assert set(outcome["reached"]) == {"approach"}  # type: ignore[arg-type]
    assert outcome["error"] == {
        "type": "RobotFault",
        "message": "protective stop",
        "safety_mode": 3,
        "runtime_state": 2,
        "robot_mode": None,
    }


def test_ctrl_c_is_recorded_and_propagates(tmp_path: Path) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    arm.fail_on_move = 1
    arm.failure = KeyboardInterrupt()
    with pytest.raises(KeyboardInterrupt):
        _run(tmp_path, arm, config, _detection())
    outcome = _records(config.audit.file)[-1]
    assert outcome["status"] == "interrupted"
    assert outcome["step"] == "approach"


def test_gripper_output_switches_between_grasp_and_retreat(tmp_path: Path) -> None:
    gripper = "  gripper: {bank: tool, index: 1, close_value: true, settle_s: 0}"
    config = _config(tmp_path, gripper=gripper)
    arm = ScriptedArm(config.audit.file)
    _run(tmp_path, arm, config, _detection())
    sequence = [c for c in arm.calls if c[0] in ("move", "output")]
    assert [kind for kind, _ in sequence] == ["move", "move", "output", "move"]
    assert sequence[2][1] == (OutputBank.TOOL, 1, True)


PLACE = """
place:
  poses:
    - [-0.30, 0.30, 0.20, 3.14159265, 0, 0]
    - [-0.40, 0.30, 0.20, 3.14159265, 0, 0]
  approach_mm: 60
  retreat_mm: 70
poses:
  home: {joints_rad: [0, -1.57, 1.57, -1.57, -1.57, 0]}
  clear: {tcp_pose: [-0.30, 0.0, 0.40, 3.14159265, 0, 0]}
capture:
  pose: home
"""


def test_capture_latches_the_flange_pose_and_the_pick_uses_it_after_the_arm_moved(
    tmp_path: Path,
) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    cell = _cell(config, arm)
    capture = cell.capture()
    latched = arm.T_base_flange.copy()
    arm.T_base_flange = arm.T_base_flange @ make_transform(np.eye(3), [0.05, 0.02, -0.03])
    result = cell.pick(_detection(), capture)
    T_flange_cam = _calibration(config).T_cal
    expected = latched @ T_flange_cam @ _detection().T_cam_obj
    np.testing.assert_allclose(result.plan.grasp, expected, atol=1e-12)
    assert result.capture.capture_id == capture.capture_id
    records = _records(config.audit.file)
    assert [r["event"] for r in records] == ["capture", "plan", "outcome"]
    assert {r["capture_id"] for r in records} == {capture.capture_id}
    assert {r["cycle"] for r in records} == {1}
    assert records[1]["flange_pose_source"] == "latched"


def test_first_feasible_candidate_is_picked_and_refused_ones_say_why(tmp_path: Path) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    arm.refuse_below_z_m = 0.05  # the controller refuses targets under 5 cm
    # The first candidate lies 200 mm deeper in the camera: its grasp is below 5 cm.
    deep = detection_from_point_mm([0.0, 0.0, 580.0], "deep")
    shallow = detection_from_point_mm([0.0, 0.0, 300.0], "shallow")
    result = _cell(config, arm).pick([deep, shallow])
    assert result.candidate == 1
    (refusal,) = result.refused
    assert refusal.candidate == 0
    assert any("safety_limits" in reason for reason in refusal.reasons)
    outcome = _records(config.audit.file)[-1]
    assert outcome["candidate"] == 1
    assert outcome["refused"][0]["candidate"] == 0  # type: ignore[index]


def test_no_feasible_candidate_moves_nothing_and_lists_each(tmp_path: Path) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    arm.within_limits = False
    candidates = [detection_from_point_mm([0.0, 0.0, z], f"c{z:g}") for z in (300.0, 350.0)]
    with pytest.raises(NoFeasibleCandidate) as caught:
        _cell(config, arm).pick(candidates)
    assert [r.candidate for r in caught.value.refusals] == [0, 1]
    assert "candidate 1 (c350)" in str(caught.value)
    assert arm.moves() == []
    assert _records(config.audit.file)[-1]["status"] == "refused"


def test_pick_with_place_puts_the_part_down_in_turn(tmp_path: Path) -> None:
    gripper = "  gripper: {bank: tool, index: 1, close_value: true, settle_s: 0}"
    config = _config(tmp_path, gripper=gripper, extra=PLACE)
    arm = ScriptedArm(config.audit.file)
    cell = _cell(config, arm)
    first = cell.pick(_detection())
    second = cell.pick(_detection())
    assert (first.status, first.place_index, second.place_index) == ("placed", 0, 1)
    moves = arm.moves()[:6]
    place = config.place.T_base_tcp[0]  # type: ignore[union-attr]
    np.testing.assert_allclose(moves[4][0], place, atol=1e-12)
    # place approach 60 mm and retreat 70 mm back along the place pose's tool z (down): above
    np.testing.assert_allclose(moves[3][0][:3, 3], place[:3, 3] + [0, 0, 0.060], atol=1e-6)
    np.testing.assert_allclose(moves[5][0][:3, 3], place[:3, 3] + [0, 0, 0.070], atol=1e-6)
    assert (moves[4][1], moves[3][1]) == (0.05, 0.25)  # slow onto the place
    outputs = [c[1] for c in arm.calls if c[0] == "output"]
    assert outputs[:2] == [(OutputBank.TOOL, 1, True), (OutputBank.TOOL, 1, False)]
    np.testing.assert_allclose(second.T_base_tcp_place, config.place.T_base_tcp[1])  # type: ignore[union-attr]


def test_fixed_targets_are_asked_once_per_session_pick_targets_every_time(tmp_path: Path) -> None:
    config = _config(tmp_path, extra=PLACE)
    arm = ScriptedArm(config.audit.file)
    cell = _cell(config, arm)
    asked = []
    for _ in range(3):  # place poses 0, 1, 0 again
        before = sum(1 for c in arm.calls if c[0] == "ask")
        cell.pick(_detection())
        asked.append(sum(1 for c in arm.calls if c[0] == "ask") - before)
    assert asked == [6, 6, 3]  # 3 pick + 3 place targets; place pose 0 is not asked again


def test_named_joint_pose_is_checked_moved_with_movej_and_audited(tmp_path: Path) -> None:
    config = _config(tmp_path, extra=PLACE)
    arm = ScriptedArm(config.audit.file)
    _cell(config, arm).move_to("home")
    (movej,) = [c[1] for c in arm.calls if c[0] == "movej"]
    assert movej[0] == (0.0, -1.57, 1.57, -1.57, -1.57, 0.0)
    plan, outcome = _records(config.audit.file)
    assert plan["operation"] == "move home"
    assert plan["checks"][-1]["name"] == "joint_safety_limits"  # type: ignore[index]
    assert outcome["status"] == "done"


def test_a_fault_halts_the_cell_until_resume(tmp_path: Path) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    arm.fail_on_move = 2
    cell = _cell(config, arm)
    with pytest.raises(RobotFault):
        cell.pick(_detection())
    assert cell.halted is not None
    assert "protective stop" in cell.halted
    moves_before = len(arm.moves())
    with pytest.raises(CellHalted, match="resume"):
        cell.pick(_detection())
    with pytest.raises(CellHalted):
        cell.move_to("anything")
    assert len(arm.moves()) == moves_before  # nothing moved while halted
    assert _records(config.audit.file)[-1]["status"] == "halted"  # the refused pick, audited
    arm.fail_on_move = None
    cell.resume(request_id="r7")
    assert cell.halted is None
    resumed = _records(config.audit.file)[-1]
    assert resumed["event"] == "resume"
    assert resumed["status"] == "ready"
    assert resumed["request_id"] == "r7"
    assert "protective stop" in str(resumed["halted"])  # why it stood, for the shift report
    assert cell.pick(_detection()).status == "picked"


@pytest.mark.parametrize(
    "refusal",
    [
        SafetyRefusal("moveL refused, nothing sent: the robot was switched to local control"),
        InputError("a defect of input met only mid-sequence"),
    ],
)
def test_a_refusal_after_the_arm_moved_is_a_fault_that_halts(
    tmp_path: Path, refusal: Exception
) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    arm.fail_on_move, arm.failure = 2, refusal  # the approach ran, the grasp is refused
    cell = _cell(config, arm)
    with pytest.raises(SequenceAborted, match="stands at 'approach'") as raised:
        cell.pick(_detection())
    assert raised.value.__cause__ is refusal
    assert ending(raised.value).exit_code == 4
    assert cell.halted is not None  # like any fault: nothing moves until resume
    assert arm.calls[-1] == ("stop", config.motion.stop_decel_mps2)
    outcome = _records(config.audit.file)[-1]
    assert outcome["status"] == "aborted"
    assert outcome["step"] == "grasp"
    assert set(outcome["reached"]) == {"approach"}  # type: ignore[arg-type]
    assert outcome["stop"] == "stopL sent"


def test_a_refusal_of_the_first_move_is_a_refusal_and_does_not_halt(tmp_path: Path) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    arm.fail_on_move = 1
    arm.failure = SafetyRefusal("moveL refused, nothing sent: local control")
    cell = _cell(config, arm)
    with pytest.raises(SafetyRefusal) as raised:
        cell.pick(_detection())
    assert not isinstance(raised.value, SequenceAborted)
    assert cell.halted is None
    assert ("stop", config.motion.stop_decel_mps2) not in arm.calls
    assert _records(config.audit.file)[-1]["status"] == "refused"


def test_resume_stays_halted_while_the_cell_is_not_ready(tmp_path: Path) -> None:
    config = _config(tmp_path)
    arm = ScriptedArm(config.audit.file)
    arm.fail_on_move = 1
    cell = _cell(config, arm)
    with pytest.raises(RobotFault):
        cell.pick(_detection())
    arm.status_value = RobotStatus(**{**vars(READY), "protective_stopped": True, "safety_mode": 3})
    with pytest.raises(SafetyRefusal, match="still not ready"):
        cell.resume()
    assert cell.halted is not None
    attempt = _records(config.audit.file)[-1]
    assert (attempt["event"], attempt["status"]) == ("resume", "not-ready")
    assert attempt["problems"]  # the reasons it stays halted


def test_move_timeout_follows_the_trapezoid_profile() -> None:
    start = np.eye(4)
    far = make_transform(np.eye(3), [1.0, 0.0, 0.0])  # cruise: 1/0.25 + 0.25/1.2 s
    assert move_timeout_s(start, far, 0.25, 1.2, 5.0) == pytest.approx(
        (4.0 + 0.25 / 1.2) * 1.5 + 5.0
    )
    near = make_transform(np.eye(3), [0.01, 0.0, 0.0])  # never reaches speed: 2 sqrt(d/a)
    assert move_timeout_s(start, near, 0.25, 1.2, 5.0) == pytest.approx(
        2.0 * math.sqrt(0.01 / 1.2) * 1.5 + 5.0
    )
    turn = make_transform(rotation_from_euler([0.0, 0.0, 1.0], "xyz", "rad"), [0.0, 0.0, 0.0])
    assert move_timeout_s(start, turn, 0.25, 1.2, 0.0) == pytest.approx((4.0 + 0.25 / 1.2) * 1.5)


# --- progress lines (progress.py) ----------------------------------------------------------------


def test_progress_step_reports_tenths_and_duration(monkeypatch: pytest.MonkeyPatch) -> None:
    stream = io.StringIO()
    clock = iter([0.0, 1.0, 1.1, 2.0, 3.0, 4.5])
    monkeypatch.setattr(progress_module.time, "monotonic", lambda: next(clock))
    with Progress(stream).step("approach") as report:
        report(0.45)  # t=1.0: shown
        report(0.55)  # t=1.1: a new tenth, but too soon after the last line
        report(0.62)  # t=2.0: shown
        report(1.0)  # t=3.0: the end has its own line
    assert stream.getvalue().splitlines() == [
        "approach",
        "approach 40%",
        "approach 60%",
        "approach done in 4.50 s",
    ]


def test_progress_step_says_when_it_failed() -> None:
    stream = io.StringIO()
    with pytest.raises(RobotFault), Progress(stream).step("grasp"):
        raise RobotFault("protective stop")
    assert stream.getvalue().splitlines()[-1].startswith("grasp failed after")


def test_quiet_progress_prints_nothing(capsys: pytest.CaptureFixture[str]) -> None:
    with Progress.quiet().step("retreat") as report:
        report(0.5)
    assert capsys.readouterr() == ("", "")


def test_a_position_only_grasp_keeps_the_tcp_yaw_not_the_flange_yaw(tmp_path: Path) -> None:
    # A TCP offset turned 0.4 rad about the tool z axis: the grasp keeps the yaw the TCP had at
    # capture. Planning from the flange pose instead would turn the tool 23 degrees.
    config = _config(tmp_path)
    config = dataclasses.replace(
        config,
        robot=dataclasses.replace(
            config.robot, T_flange_tcp=ur_pose_to_matrix([0.0, 0.0, 0.12, 0.0, 0.0, 0.4])
        ),
    )
    arm = ScriptedArm(config.audit.file)
    arm.T_flange_tcp = config.robot.T_flange_tcp
    result = _cell(config, arm).pick(detection_from_point_mm([20.0, 10.0, 350.0], "test"))
    R_base_tcp = (T_BASE_FLANGE @ arm.T_flange_tcp)[:3, :3]
    np.testing.assert_allclose(result.plan.grasp[:3, :3], R_base_tcp, atol=1e-9)
    np.testing.assert_allclose(arm.moves()[1][0][:3, :3], R_base_tcp, atol=1e-9)
