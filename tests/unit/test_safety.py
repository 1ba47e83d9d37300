"""Pre-flight checks refuse every unsafe plan listing all failures, and never move the arm."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from handeye_pick.config.hand_eye import calibration_from_config
from handeye_pick.config.load import load_config
from handeye_pick.config.schema import MotionConfig, WorkspaceConfig
from handeye_pick.detection import load_detection
from handeye_pick.errors import RobotFault, SafetyRefusal
from handeye_pick.geometry import Transform, make_transform, rotation_from_euler, ur_pose_to_matrix
from handeye_pick.hand_eye.files import (
    CELL_CONFIG,
    HandEyeMode,
    load_hand_eye,
    write_zivid_transform,
)
from handeye_pick.limits import MAX_GRASP_SPEED_MPS, MAX_JOINT_SPEED_RPS, MAX_SPEED_MPS
from handeye_pick.robot.port import (
    OutputBank,
    ProgressCallback,
    RobotArm,
    RobotMode,
    RobotStatus,
    RuntimeState,
    SafetyMode,
)
from handeye_pick.safety import (
    CheckResult,
    CornerTarget,
    JointTarget,
    PoseTarget,
    PreflightRefusal,
    cell_readiness_problems,
    chain_checks,
    check_joint_command,
    check_motion_command,
    ensure_remote_control,
    motion_problems,
    preflight,
    tilt_deg,
)

WORKSPACE = WorkspaceConfig(min_mm=(-800, -800, 0), max_mm=(800, 800, 800), max_tilt_deg=60)
MOTION = MotionConfig(speed_mps=0.25, accel_mps2=1.2, grasp_speed_mps=0.05)


def _down(x_m: float, y_m: float, z_m: float, tilt_about_x_deg: float = 0.0) -> Transform:
    """A TCP pose at (x, y, z) m with tool z straight down, tilted about the tool x axis."""
    R = rotation_from_euler([180.0 + tilt_about_x_deg, 0.0, 0.0], "xyz", "deg")
    return make_transform(R, [x_m, y_m, z_m])


TARGETS = {
    "approach": _down(0.4, 0.1, 0.3),
    "grasp": _down(0.4, 0.1, 0.2),
    "retreat": _down(0.4, 0.1, 0.35),
}


class FakeArm:
    """A RobotArm whose controller verdicts are set per target position; records every call."""

    def __init__(
        self,
        *,
        unsafe: tuple[NDArray[np.float64], ...] = (),
        unreachable: tuple[NDArray[np.float64], ...] = (),
        unsafe_joints: tuple[tuple[float, ...], ...] = (),
        fault: bool = False,
    ) -> None:
        self.unsafe = unsafe
        self.unreachable = unreachable
        self.unsafe_joints = unsafe_joints
        self.fault = fault
        self.asked: list[str] = []
        self.motion: list[str] = []

    def _matches(self, T: Transform, positions: tuple[NDArray[np.float64], ...]) -> bool:
        return any(np.allclose(T[:3, 3], p) for p in positions)

    def status(self) -> RobotStatus:
        raise NotImplementedError

    def tcp_offset(self) -> Transform:
        raise NotImplementedError

    def tcp_pose(self) -> Transform:
        raise NotImplementedError

    def flange_pose(self) -> Transform:
        raise NotImplementedError

    def is_pose_within_safety_limits(self, T_base_tcp: Transform) -> bool:
        self.asked.append("safety_limits")
        return not self._matches(T_base_tcp, self.unsafe)

    def joints_within_safety_limits(self, q_rad: tuple[float, ...]) -> bool:
        self.asked.append("joint_safety_limits")
        return tuple(q_rad) not in self.unsafe_joints

    def has_ik_solution(self, T_base_tcp: Transform) -> bool:
        self.asked.append("ik")
        if self.fault:
            raise RobotFault("getInverseKinematicsHasSolution failed", safety_mode=3)
        return not self._matches(T_base_tcp, self.unreachable)

    def move_linear(
        self,
        T_base_tcp: Transform,
        speed_mps: float,
        accel_mps2: float,
        timeout_s: float,
        on_progress: ProgressCallback | None = None,
    ) -> Transform:
        self.motion.append("move_linear")
        return T_base_tcp

    def stop_linear(self, decel_mps2: float) -> None:
        self.motion.append("stop_linear")

    def set_digital_output(self, bank: OutputBank, index: int, value: bool) -> None:
        self.motion.append("set_digital_output")

    def close(self) -> None:
        pass


def _refusal(
    targets: dict[str, Transform] = TARGETS,
    motion: MotionConfig = MOTION,
    workspace: WorkspaceConfig = WORKSPACE,
    arm: FakeArm | None = None,
) -> tuple[PreflightRefusal, FakeArm]:
    arm = arm or FakeArm()
    robot: RobotArm = arm  # mypy checks that the fake matches the Protocol
    with pytest.raises(PreflightRefusal) as info:
        preflight(_pose_targets(targets), motion, workspace, robot)
    assert arm.motion == []  # a refusal moves nothing
    return info.value, arm


def _pose_targets(targets: dict[str, Transform]) -> list[PoseTarget]:
    return [PoseTarget(name, T) for name, T in targets.items()]


def _failed(refusal: PreflightRefusal) -> list[tuple[str, str]]:
    return [(r.target, r.name) for r in refusal.results if not r.passed]


def test_a_good_plan_passes_every_check_and_asks_the_controller_per_target() -> None:
    arm = FakeArm()
    results = preflight(_pose_targets(TARGETS), MOTION, WORKSPACE, arm)
    assert all(r.passed for r in results)
    names = {(r.target, r.name) for r in results}
    for target in TARGETS:
        for check in ("workspace", "tilt", "safety_limits", "ik"):
            assert (target, check) in names
    for check in ("speed", "grasp_speed", "accel", "stop_decel"):
        assert ("motion", check) in names
    assert arm.asked.count("safety_limits") == 3
    assert arm.asked.count("ik") == 3
    assert arm.motion == []


def test_identical_targets_ask_the_controller_once_and_report_for_both() -> None:
    same = _down(0.4, 0.1, 0.3)
    targets = {"approach": same, "grasp": _down(0.4, 0.1, 0.2), "retreat": same.copy()}
    arm = FakeArm(unsafe=(same[:3, 3],))
    refusal, _ = _refusal(targets=targets, arm=arm)
    assert arm.asked.count("safety_limits") == 2
    assert arm.asked.count("ik") == 2
    assert ("approach", "safety_limits") in _failed(refusal)
    assert ("retreat", "safety_limits") in _failed(refusal)


@pytest.mark.parametrize(
    ("position_m", "expected"),
    [
        ((0.9, 0.1, 0.2), "x 900.0 mm above max 800 mm"),
        ((-0.9, 0.1, 0.2), "x -900.0 mm below min -800 mm"),
        ((0.4, 0.81, 0.2), "y 810.0 mm above max 800 mm"),
        ((0.4, -0.81, 0.2), "y -810.0 mm below min -800 mm"),
        ((0.4, 0.1, -0.001), "z -1.0 mm below min 0 mm"),
        ((0.4, 0.1, 0.95), "z 950.0 mm above max 800 mm"),
    ],
)
def test_grasp_outside_the_workspace_box_is_refused(
    position_m: tuple[float, float, float], expected: str
) -> None:
    targets = {**TARGETS, "grasp": _down(*position_m)}
    refusal, _ = _refusal(targets)
    assert _failed(refusal) == [("grasp", "workspace")]
    assert expected in str(refusal)
    assert "nothing moved" in str(refusal)


def test_box_edges_are_inside() -> None:
    targets = {"a": _down(0.8, -0.8, 0.0), "b": _down(-0.8, 0.8, 0.8)}
    preflight(_pose_targets(targets), MOTION, WORKSPACE, FakeArm())


def test_tilt_above_the_limit_is_refused() -> None:
    targets = {**TARGETS, "approach": _down(0.4, 0.1, 0.3, tilt_about_x_deg=61)}
    refusal, _ = _refusal(targets)
    assert _failed(refusal) == [("approach", "tilt")]
    assert "61.0 deg from straight down, limit 60 deg" in str(refusal)
    preflight(
        _pose_targets({"approach": _down(0.4, 0.1, 0.3, tilt_about_x_deg=59)}),
        MOTION,
        WORKSPACE,
        FakeArm(),
    )


def test_tool_pointing_up_is_refused_unless_tilt_check_is_off() -> None:
    up = make_transform(np.eye(3), [0.4, 0.1, 0.3])
    refusal, _ = _refusal({"grasp": up})
    assert _failed(refusal) == [("grasp", "tilt")]
    off = WorkspaceConfig(WORKSPACE.min_mm, WORKSPACE.max_mm, max_tilt_deg=180)
    preflight(_pose_targets({"grasp": up}), MOTION, off, FakeArm())


@pytest.mark.parametrize(
    ("motion", "failed"),
    [
        (MotionConfig(speed_mps=1.5, accel_mps2=1.2, grasp_speed_mps=0.05), "speed"),
        (MotionConfig(speed_mps=0.0, accel_mps2=1.2, grasp_speed_mps=0.05), "speed"),
        (MotionConfig(speed_mps=math.nan, accel_mps2=1.2, grasp_speed_mps=0.05), "speed"),
        (MotionConfig(speed_mps=0.25, accel_mps2=1.2, grasp_speed_mps=0.3), "grasp_speed"),
        (MotionConfig(speed_mps=0.25, accel_mps2=1.2, grasp_speed_mps=-0.05), "grasp_speed"),
        (MotionConfig(speed_mps=0.25, accel_mps2=10.0, grasp_speed_mps=0.05), "accel"),
        (MotionConfig(speed_mps=0.25, accel_mps2=0.0, grasp_speed_mps=0.05), "accel"),
        (MotionConfig(0.25, 1.2, 0.05, stop_decel_mps2=0.5), "stop_decel"),
        (MotionConfig(0.25, 1.2, 0.05, stop_decel_mps2=200.0), "stop_decel"),
    ],
)
def test_speed_caps_are_enforced_at_preflight(motion: MotionConfig, failed: str) -> None:
    refusal, _ = _refusal(motion=motion)
    assert _failed(refusal) == [("motion", failed)]


@pytest.mark.parametrize("check", ["safety_limits", "ik"])
def test_controller_refusal_of_one_target_is_refused(check: str) -> None:
    grasp_position = TARGETS["grasp"][:3, 3]
    arm = (
        FakeArm(unsafe=(grasp_position,))
        if check == "safety_limits"
        else FakeArm(unreachable=(grasp_position,))
    )
    refusal, _ = _refusal(arm=arm)
    assert _failed(refusal) == [("grasp", check)]
    assert f"grasp {check}: controller" in str(refusal)


def test_every_failure_is_listed_at_once() -> None:
    targets = {
        "approach": _down(0.4, 0.1, 0.9, tilt_about_x_deg=80),
        "grasp": _down(0.4, 0.1, 0.2),
        "retreat": _down(0.4, 0.1, 0.3),
    }
    arm = FakeArm(unsafe=(targets["retreat"][:3, 3],), unreachable=(targets["grasp"][:3, 3],))
    motion = MotionConfig(speed_mps=2.0, accel_mps2=1.2, grasp_speed_mps=0.05)
    refusal, _ = _refusal(targets, motion=motion, arm=arm)
    assert _failed(refusal) == [
        ("motion", "speed"),
        ("approach", "workspace"),
        ("approach", "tilt"),
        ("grasp", "ik"),
        ("retreat", "safety_limits"),
    ]
    assert "5 of 16 checks failed" in str(refusal)
    assert isinstance(refusal, SafetyRefusal)
    assert all(isinstance(r, CheckResult) for r in refusal.results)
    assert arm.asked.count("ik") == 3  # the controller is asked about every target regardless


def test_a_controller_that_cannot_answer_raises_its_robot_error() -> None:
    arm = FakeArm(fault=True)
    with pytest.raises(RobotFault):
        preflight(_pose_targets(TARGETS), MOTION, WORKSPACE, arm)
    assert arm.motion == []


@pytest.mark.parametrize(
    ("speed", "accel", "cap"),
    [
        (0.0, 1.2, MAX_SPEED_MPS),
        (-0.1, 1.2, MAX_SPEED_MPS),
        (math.nan, 1.2, MAX_SPEED_MPS),
        (1.01, 1.2, MAX_SPEED_MPS),
        (3.5, 1.2, 5.0),  # ur_rtde's own 3 m/s limit holds whatever cap is passed
        (0.3, 1.2, MAX_GRASP_SPEED_MPS),
        (0.25, 4.5, MAX_SPEED_MPS),
        (0.25, 0.0, MAX_SPEED_MPS),
        (0.25, math.inf, MAX_SPEED_MPS),
    ],
)
def test_motion_command_outside_caps_is_refused(speed: float, accel: float, cap: float) -> None:
    with pytest.raises(SafetyRefusal, match="motion command refused, nothing sent"):
        check_motion_command(speed, accel, max_speed_mps=cap)


def test_motion_command_at_the_caps_is_allowed() -> None:
    check_motion_command(MAX_SPEED_MPS, 4.0)
    check_motion_command(MAX_GRASP_SPEED_MPS, 1.2, max_speed_mps=MAX_GRASP_SPEED_MPS)


@pytest.mark.parametrize("speed_rps", [0.0, -0.1, math.nan, MAX_JOINT_SPEED_RPS * 1.001])
def test_a_joint_speed_outside_its_cap_is_refused_saying_the_range(speed_rps: float) -> None:
    with pytest.raises(SafetyRefusal) as info:
        check_joint_command(speed_rps)
    assert str(info.value) == (
        f"motion command refused, nothing sent: joint speed {speed_rps:g} rad/s outside "
        f"(0, {MAX_JOINT_SPEED_RPS:g}] rad/s"
    )


def test_a_joint_speed_at_its_cap_is_allowed() -> None:
    check_joint_command(MAX_JOINT_SPEED_RPS)
    check_joint_command(1e-6)


HOME_Q = (0.0, -math.pi / 2, math.pi / 2, -math.pi / 2, -math.pi / 2, 0.0)
FAR_Q = (0.5, -1.0, 2.0, -1.2, -1.5707, 3.0)


def test_a_joint_target_outside_the_controller_limits_is_refused_in_degrees() -> None:
    arm = FakeArm(unsafe_joints=(FAR_Q,))
    joints = [JointTarget("home", HOME_Q), JointTarget("drop", FAR_Q)]
    with pytest.raises(PreflightRefusal) as info:
        preflight(_pose_targets(TARGETS), MOTION, WORKSPACE, arm, joint_targets=joints)
    results = {r.target: r for r in info.value.results if r.name == "joint_safety_limits"}
    assert results["home"].passed
    assert results["home"].detail == (
        "controller safety limits accept joints [0.0, -90.0, 90.0, -90.0, -90.0, 0.0] deg"
    )
    assert not results["drop"].passed
    assert results["drop"].detail == (
        "controller safety limits refuse joints [28.6, -57.3, 114.6, -68.8, -90.0, 171.9] deg"
    )
    assert arm.motion == []


def test_a_joint_target_is_asked_once_per_session() -> None:
    arm = FakeArm()
    session: dict[bytes, tuple[bool, bool]] = {}
    for _ in range(2):
        preflight(
            _pose_targets(TARGETS), MOTION, WORKSPACE, arm,
            joint_targets=[JointTarget("home", HOME_Q)], verdicts=session,
        )  # fmt: skip
    assert arm.asked.count("joint_safety_limits") == 1


@pytest.mark.parametrize(
    ("center_x_m", "passed", "why"),
    [
        (0.4, True, ""),
        (0.75, False, "x 850.0 mm above max 800 mm"),
        (-0.75, False, "x -850.0 mm below min -800 mm"),
    ],
)
def test_a_blend_corner_must_stay_inside_the_box_and_says_its_radius_in_mm(
    center_x_m: float, passed: bool, why: str
) -> None:
    corner = CornerTarget(
        "place_approach", np.array([center_x_m, 0.1, 0.3]), 0.1, np.array([0.1, 0.1, 0.0])
    )
    if passed:
        results = preflight(_pose_targets(TARGETS), MOTION, WORKSPACE, FakeArm(), corners=[corner])
    else:
        with pytest.raises(PreflightRefusal) as info:
            preflight(_pose_targets(TARGETS), MOTION, WORKSPACE, FakeArm(), corners=[corner])
        results = info.value.results
    (check,) = [r for r in results if r.name == "corner_workspace"]
    assert (check.target, check.passed) == ("place_approach", passed)
    where = "a 100.0 mm blend around the target"
    if passed:
        assert check.detail == f"{where} stays inside the box"
    else:
        assert check.detail == f"{where} reaches out: {why}"


@pytest.mark.parametrize(
    ("euler_deg", "expected"),
    [([180, 0, 0], 0.0), ([180, 0, 77], 0.0), ([90, 0, 0], 90.0), ([0, 0, 0], 180.0)],
)
def test_tilt_is_measured_from_straight_down(euler_deg: list[float], expected: float) -> None:
    T = make_transform(rotation_from_euler(euler_deg, "xyz", "deg"), [0, 0, 0])
    assert math.isclose(tilt_deg(T), expected, abs_tol=1e-9)


# --- cell readiness -------------------------------------------------------------------------------

READY = RobotStatus(
    controller_version="5.15.0",
    robot_mode=RobotMode.RUNNING,
    safety_mode=SafetyMode.NORMAL,
    runtime_state=RuntimeState.PLAYING,
    remote_control=True,
    protective_stopped=False,
    emergency_stopped=False,
)
TCP = make_transform(np.eye(3), [0.0, 0.0, 0.15])


def _problems(status: RobotStatus = READY, actual: Transform = TCP) -> list[str]:
    return cell_readiness_problems(status, actual, TCP, tolerance_mm=1.0, tolerance_deg=1.0)


def test_a_ready_cell_has_no_problems() -> None:
    assert _problems() == []
    assert _problems(dataclasses.replace(READY, safety_mode=SafetyMode.REDUCED)) == []


@pytest.mark.parametrize(
    ("changes", "expected"),
    [
        ({"remote_control": False}, "switch to Remote Control"),
        ({"protective_stopped": True}, "protective stop"),
        ({"safety_mode": SafetyMode.PROTECTIVE_STOP}, "protective stop"),
        ({"emergency_stopped": True}, "release the emergency stop"),
        ({"safety_mode": SafetyMode.ROBOT_EMERGENCY_STOP}, "release the emergency stop"),
        ({"safety_mode": SafetyMode.SAFEGUARD_STOP}, "safeguard stop"),
        ({"safety_mode": SafetyMode.FAULT}, "safety system reports FAULT"),
        ({"safety_mode": SafetyMode.VIOLATION}, "safety system reports VIOLATION"),
        ({"robot_mode": RobotMode.POWER_OFF}, "robot mode POWER_OFF): on the pendant power it on"),
        ({"robot_mode": RobotMode.IDLE}, "release the brakes"),
        ({"robot_mode": 42}, "robot mode unknown (42)"),
        ({"runtime_state": RuntimeState.STOPPED}, "program is not running (runtime state STOPPED"),
    ],
)
def test_each_not_ready_condition_is_one_problem_saying_what_to_do(
    changes: dict[str, object], expected: str
) -> None:
    status = dataclasses.replace(READY, **changes)  # type: ignore[arg-type]
    problems = _problems(status)
    assert len(problems) == 1
    assert expected in problems[0]


def test_several_problems_are_all_reported() -> None:
    status = dataclasses.replace(READY, remote_control=False, emergency_stopped=True)
    assert len(_problems(status)) == 2


@pytest.mark.parametrize(
    ("actual", "ready"),
    [
        (make_transform(np.eye(3), [0.0, 0.0, 0.1509]), True),  # 0.9 mm
        (make_transform(np.eye(3), [0.0, 0.0, 0.152]), False),  # 2 mm
        (make_transform(np.eye(3), [0.0, 0.0, 0.0]), False),  # no TCP set on the pendant
        (make_transform(rotation_from_euler([0, 0, 0.9], "xyz", "deg"), [0, 0, 0.15]), True),
        (make_transform(rotation_from_euler([0, 0, 2.0], "xyz", "deg"), [0, 0, 0.15]), False),
    ],
)
def test_tcp_offset_must_match_the_config_within_tolerance(actual: Transform, ready: bool) -> None:
    problems = _problems(actual=actual)
    assert (problems == []) is ready
    if not ready:
        assert "robot.tcp_offset" in problems[0]
        assert "Installation > General > TCP" in problems[0]


ROOT = Path(__file__).resolve().parents[2]
# A flange pose no UR reaches (m, rad): a wrist camera there sees the demo object out of reach.
FLANGE_OUT_OF_REACH = ur_pose_to_matrix([0.0, 2.5, 0.5, math.pi, 0.0, 0.0])


@pytest.mark.parametrize("acknowledged", [False, True])
def test_the_chain_checks_of_a_wrist_camera_use_the_flange_and_say_how_to_acknowledge(
    acknowledged: bool,
) -> None:
    config = load_config(ROOT / "config" / "demo.yaml")
    if acknowledged:
        hand_eye = dataclasses.replace(config.hand_eye, acknowledge=("object-within-reach",))
        config = dataclasses.replace(config, hand_eye=hand_eye)
    calibration = calibration_from_config(config)
    assert calibration.mode is HandEyeMode.EYE_IN_HAND
    T_cam_obj = load_detection(ROOT / "config" / "demo" / "detection.yaml").T_cam_obj
    assert chain_checks(config, calibration, T_cam_obj, None) == []
    (result,) = chain_checks(config, calibration, T_cam_obj, FLANGE_OUT_OF_REACH)
    assert (result.name, result.target, result.passed) == (
        "plausible object-within-reach", "chain", acknowledged,
    )  # fmt: skip
    assert result.detail.startswith("the object is ")
    assert result.detail.endswith(
        "(acknowledged in hand_eye.acknowledge)"
        if acknowledged
        else "(an unusual mount acknowledges it: hand_eye.acknowledge: [object-within-reach])"
    )


def test_each_pose_check_says_the_tcp_position_in_mm_and_what_it_found() -> None:
    targets = {
        "approach": _down(0.90026, 0.1, 0.9),  # outside the box on two axes
        "grasp": _down(0.40026, 0.1, 0.2),
    }
    arm = FakeArm(unsafe=(targets["grasp"][:3, 3],), unreachable=(targets["approach"][:3, 3],))
    refusal, _ = _refusal(targets, arm=arm)
    details = {(r.target, r.name): r.detail for r in refusal.results}
    approach, grasp = "the TCP at [900.3, 100.0, 900.0] mm", "the TCP at [400.3, 100.0, 200.0] mm"
    assert details["approach", "workspace"] == (
        f"{approach}: x 900.3 mm above max 800 mm, z 900.0 mm above max 800 mm"
    )
    assert details["approach", "ik"] == f"controller finds no inverse kinematics for {approach}"
    assert details["grasp", "workspace"] == f"{grasp} inside the box"
    assert details["approach", "safety_limits"] == f"controller safety limits accept {approach}"
    assert details["grasp", "safety_limits"] == f"controller safety limits refuse {grasp}"
    assert details["grasp", "ik"] == f"controller finds inverse kinematics for {grasp}"


def test_motion_problems_name_the_value_its_unit_and_the_allowed_range() -> None:
    assert motion_problems(2.0, 9.0, MAX_SPEED_MPS) == [
        "speed 2 m/s outside (0, 1] m/s",
        "acceleration 9 m/s^2 outside (0, 4] m/s^2",
    ]
    with pytest.raises(SafetyRefusal) as info:
        check_motion_command(2.0, 9.0)
    assert str(info.value) == (
        "motion command refused, nothing sent: speed 2 m/s outside (0, 1] m/s; "
        "acceleration 9 m/s^2 outside (0, 4] m/s^2"
    )


@pytest.mark.parametrize(
    ("note", "ending"), [("", "grasp tilt: b; place ik: c"), ("n", "grasp tilt: b; place ik: c; n")]
)
def test_a_refusal_lists_every_failed_check_then_its_note(note: str, ending: str) -> None:
    results = [
        CheckResult("speed", "motion", True, "a"),
        CheckResult("tilt", "grasp", False, "b"),
        CheckResult("ik", "place", False, "c"),
    ]
    assert str(PreflightRefusal(results, note)) == (
        f"pre-flight checks refused the pick, nothing moved (2 of 3 checks failed): {ending}"
    )
    assert str(PreflightRefusal(results)) == str(PreflightRefusal(results, ""))


def test_a_move_on_a_robot_in_local_control_is_refused_saying_what_to_do() -> None:
    ensure_remote_control(True, "127.0.0.9", "moveL")
    with pytest.raises(SafetyRefusal) as info:
        ensure_remote_control(False, "127.0.0.9", "moveL")
    assert str(info.value) == (
        "moveL on 127.0.0.9 refused, nothing sent: the robot was switched to local control; "
        "switch the teach pendant back to Remote Control"
    )


def test_the_motion_checks_say_each_value_with_its_unit_and_cap() -> None:
    motion = MotionConfig(speed_mps=2.0, accel_mps2=9.0, grasp_speed_mps=0.3)
    refusal, _ = _refusal(motion=motion)
    details = {r.name: r.detail for r in refusal.results if r.target == "motion"}
    assert details["speed"] == "speed 2 m/s outside (0, 1] m/s"
    assert details["grasp_speed"] == (
        f"grasp speed 0.3 m/s outside (0, {MAX_GRASP_SPEED_MPS:g}] m/s"
    )
    assert details["accel"] == "acceleration 9 m/s^2 outside (0, 4] m/s^2"
    ok = {r.name: r.detail for r in preflight(_pose_targets(TARGETS), MOTION, WORKSPACE, FakeArm())}
    assert ok["speed"] == "0.25 m/s within caps"
    assert ok["accel"] == "1.2 m/s^2 within caps"


def test_the_chain_checks_of_a_fixed_camera_use_the_cell_workspace(tmp_path: Path) -> None:
    """A camera 1 m above the demo's workspace looking up, not at it: refused only because the
    chain checks are given the cell's workspace."""
    config = load_config(ROOT / "config" / "demo.yaml")
    path = tmp_path / "eye_to_hand.yaml"
    write_zivid_transform(path, make_transform(np.diag([1.0, 1.0, 1.0]), [0.0, -0.4, 1.0]), "mm")
    calibration = load_hand_eye(path, HandEyeMode.EYE_TO_HAND, "mm", False, settings=CELL_CONFIG)
    names = [r.name for r in chain_checks(config, calibration, None, None)]
    assert "plausible camera-looks-at-workspace" in names
