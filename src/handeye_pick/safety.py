"""Every check that can refuse a motion, and ``preflight``, the one place that runs the target
checks before a sequence moves.

Nothing here moves the robot. The cell's sequence runner calls, in this order: ``ensure_not_halted``
(a fault halted the cell), ``ensure_ready`` (the controller's modes, the session's program, the
active TCP offset against the config), ``chain_checks`` (the hand-eye chain is plausible) and
``preflight`` (every target: workspace, tilt, motion caps, the controller's safety limits and
IK), which refuses with a ``PreflightRefusal`` listing all failures at once, so an operator fixes
them in one go. ``check_motion_command`` and ``check_joint_command`` guard the speed of each
single motion command right before it is sent.

Frames and units: targets are ``T_base_tcp`` (m); the workspace box is in mm in the base frame;
tilt is the angle between the tool z axis and straight down (base -z), in degrees.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from handeye_pick.config.schema import CellConfig, MotionConfig, RobotConfig, WorkspaceConfig
from handeye_pick.errors import CellHalted, PlanRefused, SafetyRefusal
from handeye_pick.geometry import Transform, matrix_to_ur_pose, rotation_angle_between
from handeye_pick.hand_eye.files import HandEyeCalibration, HandEyeMode
from handeye_pick.hand_eye.plausibility import chain_problems
from handeye_pick.limits import (
    MAX_ACCEL_MPS2,
    MAX_GRASP_SPEED_MPS,
    MAX_JOINT_SPEED_RPS,
    MAX_SPEED_MPS,
    UR_MAX_SPEED_MPS,
    stop_decel_problem,
)
from handeye_pick.robot.port import (
    RobotArm,
    RobotMode,
    RobotStatus,
    RuntimeState,
    SafetyMode,
    mode_name,
)


@dataclass(frozen=True)
class CheckResult:
    """One pre-flight check on one target (or on the motion parameters, target "motion")."""

    name: str  # workspace, tilt, safety_limits, ik, speed, ..., collision (docs/scene.md)
    target: str  # approach, grasp, retreat, ... or "motion"
    passed: bool
    detail: str  # what was measured against what limit

    @property
    def line(self) -> str:
        """How a refusal (and ``status``) lists it: ``grasp workspace: ...``."""
        return f"{self.target} {self.name}: {self.detail}"


class PreflightRefusal(PlanRefused):
    """At least one pre-flight check failed; nothing moved. ``results`` holds every check;
    ``note``, when given, ends the message (e.g. which flange pose the targets came from)."""

    def __init__(self, results: list[CheckResult], note: str = "") -> None:
        failed = [r for r in results if not r.passed]
        lines = "; ".join(r.line for r in failed)
        super().__init__(
            f"pre-flight checks refused the pick, nothing moved ({len(failed)} of "
            f"{len(results)} checks failed): {lines}{'; ' + note if note else ''}"
        )
        self.results = results


# --- motion parameters --------------------------------------------------------------------------


def _speed_problem(what: str, value: float, maximum: float, unit: str) -> str | None:
    """None when 0 < value <= maximum; "not > 0" also refuses NaN, and a 0 speed would make the
    controller protective-stop."""
    if 0.0 < value <= maximum:
        return None
    return f"{what} {value:g} {unit} outside (0, {maximum:g}] {unit}"


def motion_problems(speed_mps: float, accel_mps2: float, max_speed_mps: float) -> list[str]:
    """What is wrong with a moveL's speed and acceleration; empty when both are within caps.

    ``max_speed_mps`` is the cap for this kind of move (``MAX_SPEED_MPS`` or
    ``MAX_GRASP_SPEED_MPS``); ``MAX_ACCEL_MPS2`` applies to every move.
    """
    problems = [
        _speed_problem("speed", speed_mps, min(max_speed_mps, UR_MAX_SPEED_MPS), "m/s"),
        _speed_problem("acceleration", accel_mps2, MAX_ACCEL_MPS2, "m/s^2"),
    ]
    return [p for p in problems if p is not None]


def check_motion_command(
    speed_mps: float, accel_mps2: float, *, max_speed_mps: float = MAX_SPEED_MPS
) -> None:
    """Raise ``SafetyRefusal`` before sending a move whose speed or acceleration is out of caps.

    The pick runner calls this for every moveL it sends (``max_speed_mps=MAX_GRASP_SPEED_MPS``
    for the grasp move), so a parameter that never went through the config is still capped.
    """
    problems = motion_problems(speed_mps, accel_mps2, max_speed_mps)
    if problems:
        raise SafetyRefusal(f"motion command refused, nothing sent: {'; '.join(problems)}")


def check_joint_command(speed_rps: float) -> None:
    """Raise ``SafetyRefusal`` before sending a moveJ whose joint speed (rad/s) is out of caps."""
    if not 0.0 < speed_rps <= MAX_JOINT_SPEED_RPS:
        raise SafetyRefusal(
            f"motion command refused, nothing sent: joint speed {speed_rps:g} rad/s outside "
            f"(0, {MAX_JOINT_SPEED_RPS:g}] rad/s"
        )


def _motion_checks(speeds: MotionConfig) -> list[CheckResult]:
    checks = {
        "speed": _speed_problem("speed", speeds.speed_mps, MAX_SPEED_MPS, "m/s"),
        "grasp_speed": _speed_problem(
            "grasp speed", speeds.grasp_speed_mps, MAX_GRASP_SPEED_MPS, "m/s"
        ),
        "accel": _speed_problem("acceleration", speeds.accel_mps2, MAX_ACCEL_MPS2, "m/s^2"),
        "stop_decel": stop_decel_problem(speeds.stop_decel_mps2, speeds.accel_mps2),
    }
    values = {
        "speed": f"{speeds.speed_mps:g} m/s",
        "grasp_speed": f"{speeds.grasp_speed_mps:g} m/s",
        "accel": f"{speeds.accel_mps2:g} m/s^2",
        "stop_decel": f"{speeds.stop_decel_mps2:g} m/s^2",
    }
    return [
        CheckResult(name, "motion", problem is None, problem or f"{values[name]} within caps")
        for name, problem in checks.items()
    ]


# --- geometric checks on one target -------------------------------------------------------------


def tilt_deg(T_base_tcp: Transform) -> float:
    """Angle in degrees between the tool z axis and straight down (base -z); 0 = pointing down."""
    z = T_base_tcp[:3, 2]
    # atan2 keeps small angles exact where acos of a cosine near 1 would not.
    return math.degrees(math.atan2(math.hypot(z[0], z[1]), -z[2]))


def workspace_problem(T_base_tcp: Transform, workspace: WorkspaceConfig) -> str | None:
    """Why the TCP position lies outside the workspace box, or None when it is inside."""
    return _box_problem(T_base_tcp[:3, 3], np.zeros(3), workspace)


def _box_problem(
    center_m: NDArray[np.float64], extent_m: NDArray[np.float64], workspace: WorkspaceConfig
) -> str | None:
    """Why the box ``center_m`` +- ``extent_m`` (base frame, m) reaches outside the workspace,
    or None when it lies inside."""
    low_mm, high_mm = (center_m - extent_m) * 1000.0, (center_m + extent_m) * 1000.0
    outside = []
    for axis, low, high, box_low, box_high in zip(
        "xyz", low_mm, high_mm, workspace.min_mm, workspace.max_mm, strict=True
    ):
        if not low >= box_low:
            outside.append(f"{axis} {low:.1f} mm below min {box_low:g} mm")
        elif not high <= box_high:
            outside.append(f"{axis} {high:.1f} mm above max {box_high:g} mm")
    return ", ".join(outside) if outside else None


ControllerVerdicts = dict[bytes, tuple[bool, bool]]
"""The controller's (within safety limits, has IK) per target, keyed by the target's bytes."""


@dataclass(frozen=True)
class PoseTarget:
    """A moveL target ``T_base_tcp`` (m) to check. ``fixed`` targets come from the config
    (place and named poses): the controller's verdict on them may be reused in a session."""

    name: str
    T_base_tcp: Transform
    fixed: bool = False


@dataclass(frozen=True)
class CornerTarget:
    """A blended target: the TCP passes within ``radius_m`` of ``center_m`` (base frame, m),
    inside the disc of that radius in the plane of its two segments, whose half-size along
    the base axes is ``extent_m`` (``cell/blend.py``)."""

    name: str
    center_m: NDArray[np.float64]
    radius_m: float
    extent_m: NDArray[np.float64]


@dataclass(frozen=True)
class JointTarget:
    """A moveJ target (joint positions, rad) of a named pose; always a fixed target."""

    name: str
    q_rad: tuple[float, ...]


def _ask_controller(
    T_base_tcp: Transform, arm: RobotArm, asked: ControllerVerdicts
) -> tuple[bool, bool]:
    # Each query costs a few RTDE cycles; a target identical to one already checked (approach
    # and retreat of a straight-down pick with equal distances) gets the same answer.
    key = T_base_tcp.tobytes()
    if key not in asked:
        asked[key] = (arm.is_pose_within_safety_limits(T_base_tcp), arm.has_ik_solution(T_base_tcp))
    return asked[key]


def _target_checks(
    name: str,
    T_base_tcp: Transform,
    workspace: WorkspaceConfig,
    verdict: tuple[bool, bool],
) -> list[CheckResult]:
    p_mm = np.round(T_base_tcp[:3, 3] * 1000.0, 1).tolist()
    where = f"the TCP at {p_mm} mm"
    box = workspace_problem(T_base_tcp, workspace)
    tilt = tilt_deg(T_base_tcp)
    within, reachable = verdict
    return [
        CheckResult(
            "workspace",
            name,
            box is None,
            f"{where} inside the box" if box is None else f"{where}: {box}",
        ),
        CheckResult(
            "tilt",
            name,
            tilt <= workspace.max_tilt_deg,
            f"tool z {tilt:.1f} deg from straight down, limit {workspace.max_tilt_deg:g} deg",
        ),
        CheckResult(
            "safety_limits",
            name,
            within,
            f"controller safety limits {'accept' if within else 'refuse'} {where}",
        ),
        CheckResult(
            "ik",
            name,
            reachable,
            f"controller {'finds' if reachable else 'finds no'} inverse kinematics for {where}",
        ),
    ]


def _corner_check(corner: CornerTarget, workspace: WorkspaceConfig) -> CheckResult:
    box = _box_problem(corner.center_m, corner.extent_m, workspace)
    where = f"a {corner.radius_m * 1000.0:.1f} mm blend around the target"
    return CheckResult(
        "corner_workspace",
        corner.name,
        box is None,
        f"{where} stays inside the box" if box is None else f"{where} reaches out: {box}",
    )


def _joint_checks(target: JointTarget, arm: RobotArm, verdicts: ControllerVerdicts) -> CheckResult:
    key = np.array(target.q_rad).tobytes()
    if key not in verdicts:
        within = arm.joints_within_safety_limits(target.q_rad)
        verdicts[key] = (within, within)
    within = verdicts[key][0]
    q_deg = np.round(np.degrees(target.q_rad), 1).tolist()
    return CheckResult(
        "joint_safety_limits",
        target.name,
        within,
        f"controller safety limits {'accept' if within else 'refuse'} joints {q_deg} deg",
    )


def preflight(
    targets: Sequence[PoseTarget],
    speeds: MotionConfig,
    workspace: WorkspaceConfig,
    arm: RobotArm,
    *,
    joint_targets: Sequence[JointTarget] = (),
    corners: Sequence[CornerTarget] = (),
    verdicts: ControllerVerdicts | None = None,
) -> list[CheckResult]:
    """Run every check on every target and on the motion parameters.

    Pose targets (``T_base_tcp``): workspace box, tilt, the controller's safety limits and IK.
    Joint targets (a named pose taught on the pendant): the controller's joint safety limits.
    Blended corners: all the TCP may pass through while rounding one lies in the workspace box.
    Returns all results when every check passed; otherwise raises ``PreflightRefusal`` carrying
    all results (for the audit record). Only asks the controller, never moves it, and asks once
    per distinct target; verdicts on fixed targets are kept in ``verdicts`` for the caller's
    session. A controller that cannot answer raises its ``RobotError`` unchanged.
    """
    results = _motion_checks(speeds)
    asked: ControllerVerdicts = {}
    session = verdicts if verdicts is not None else {}
    for target in targets:
        cache = session if target.fixed else asked
        verdict = _ask_controller(target.T_base_tcp, arm, cache)
        results.extend(_target_checks(target.name, target.T_base_tcp, workspace, verdict))
    results.extend(_joint_checks(target, arm, session) for target in joint_targets)
    results.extend(_corner_check(corner, workspace) for corner in corners)
    if not all(r.passed for r in results):
        raise PreflightRefusal(results)
    return results


# --- is the cell ready to move? -----------------------------------------------------------------


def tcp_offset_difference(
    T_flange_tcp_actual: Transform, T_flange_tcp_configured: Transform
) -> tuple[float, float]:
    """How far the active TCP offset is from the configured one: (translation mm, rotation deg)."""
    offset_mm = 1000.0 * float(
        np.linalg.norm(T_flange_tcp_actual[:3, 3] - T_flange_tcp_configured[:3, 3])
    )
    offset_deg = math.degrees(
        rotation_angle_between(T_flange_tcp_actual[:3, :3], T_flange_tcp_configured[:3, :3])
    )
    return offset_mm, offset_deg


def cell_readiness_problems(
    status: RobotStatus,
    T_flange_tcp_actual: Transform,
    T_flange_tcp_configured: Transform,
    *,
    tolerance_mm: float,
    tolerance_deg: float,
) -> list[str]:
    """Why a connected session cannot start a pick, each with what to do on the pendant; empty
    when ready. The session's own control program must be running.

    ``T_flange_tcp_actual`` is the TCP offset active on the controller, ``T_flange_tcp_configured``
    the one in the cell config (both m); they must agree within the tolerances, or every target
    would be off by their difference.
    """
    problems = controller_problems(status)
    if status.runtime_state != RuntimeState.PLAYING:
        problems.append(
            "the remote control program is not running (runtime state "
            f"{mode_name(RuntimeState, status.runtime_state)}): stop any program running on the "
            "pendant and connect again"
        )
    problems.extend(
        tcp_offset_problems(
            T_flange_tcp_actual,
            T_flange_tcp_configured,
            tolerance_mm=tolerance_mm,
            tolerance_deg=tolerance_deg,
        )
    )
    return problems


def controller_problems(status: RobotStatus) -> list[str]:
    """Why the controller cannot run a pick whoever asks (remote control, stops, safety faults,
    arm not running), each with what to do on the pendant; the program is judged by the caller."""
    problems = []
    safety = status.safety_mode
    if not status.remote_control:
        problems.append(
            "robot is in local control: on the teach pendant switch to Remote Control "
            "(profile icon, top right), then start again"
        )
    if status.emergency_stopped or safety in (
        SafetyMode.SYSTEM_EMERGENCY_STOP,
        SafetyMode.ROBOT_EMERGENCY_STOP,
    ):
        problems.append(
            "emergency stop is active: make the cell safe, release the emergency stop button, "
            "then power on and release the brakes on the pendant"
        )
    if status.protective_stopped or safety == SafetyMode.PROTECTIVE_STOP:
        problems.append(
            "protective stop is active: find and remove the cause, then press 'Enable robot' "
            "on the pendant (nothing unlocks it automatically)"
        )
    if safety == SafetyMode.SAFEGUARD_STOP:
        problems.append(
            "safeguard stop is active: close the safeguard (door, light curtain) and reset it "
            "as the cell requires"
        )
    if safety in (SafetyMode.VIOLATION, SafetyMode.FAULT, SafetyMode.RECOVERY):
        problems.append(
            f"safety system reports {mode_name(SafetyMode, safety)}: read the pendant's log, clear "
            "the fault there (restart the safety system if it asks), then try again"
        )
    if status.robot_mode != RobotMode.RUNNING:
        problems.append(
            f"arm is not running (robot mode {mode_name(RobotMode, status.robot_mode)}): on the "
            "pendant power it on and release the brakes (ON, then START)"
        )
    return problems


def tcp_offset_problems(
    T_flange_tcp_actual: Transform,
    T_flange_tcp_configured: Transform,
    *,
    tolerance_mm: float,
    tolerance_deg: float,
) -> list[str]:
    """The active TCP offset against the configured one (both m), as a problem list (empty or
    one entry naming both offsets, the difference and the tolerances)."""
    offset_mm, offset_deg = tcp_offset_difference(T_flange_tcp_actual, T_flange_tcp_configured)
    if offset_mm <= tolerance_mm and offset_deg <= tolerance_deg:
        return []
    actual = np.round(matrix_to_ur_pose(T_flange_tcp_actual), 4).tolist()
    configured = np.round(matrix_to_ur_pose(T_flange_tcp_configured), 4).tolist()
    return [
        f"active TCP offset {actual} (m, rad) differs from robot.tcp_offset {configured} by "
        f"{offset_mm:.1f} mm and {offset_deg:.2f} deg (tolerance {tolerance_mm:g} mm, "
        f"{tolerance_deg:g} deg): select the right TCP on the pendant (Installation > "
        "General > TCP) or correct robot.tcp_offset in the config"
    ]


def ensure_remote_control(remote_control: bool, host: str, command: str) -> None:
    """Refuse a motion ``command`` (moveL, moveJ) on a robot switched to local control since the
    sequence was checked: read right before each move is sent."""
    if not remote_control:
        raise SafetyRefusal(
            f"{command} on {host} refused, nothing sent: the robot was switched to "
            "local control; switch the teach pendant back to Remote Control"
        )


def ensure_not_halted(host: str, halted: str | None) -> None:
    """Refuse every motion of a cell a fault or a stop request halted (``halted`` says why)
    until it resumes."""
    if halted is not None:
        raise CellHalted(
            f"cell {host} is halted ({halted}): clear the cause, then resume; nothing moved"
        )


def readiness_problems(
    status: RobotStatus, T_flange_tcp: Transform, robot: RobotConfig
) -> list[str]:
    """``cell_readiness_problems`` with the configured TCP offset (m) and its tolerances."""
    return cell_readiness_problems(
        status,
        T_flange_tcp,
        robot.T_flange_tcp,
        tolerance_mm=robot.tcp_offset_tolerance_mm,
        tolerance_deg=robot.tcp_offset_tolerance_deg,
    )


def ensure_ready(status: RobotStatus, T_flange_tcp: Transform, robot: RobotConfig) -> None:
    """Refuse a sequence on a cell that is not ready, every problem listed (nothing moved)."""
    problems = readiness_problems(status, T_flange_tcp, robot)
    if problems:
        raise SafetyRefusal(f"cell on {robot.host} is not ready: " + "; ".join(problems))


def chain_checks(
    config: CellConfig,
    calibration: HandEyeCalibration,
    T_cam_obj: Transform | None,
    T_base_flange: Transform | None,
) -> list[CheckResult]:
    """The hand-eye chain's plausibility (``plausibility.chain_problems``: an inverted or
    swapped calibration, an object out of the camera's range) as pre-flight results, target
    ``chain``; a check the config acknowledges passes and says so. ``T_base_flange`` (m) is the
    flange at acquisition, used for eye-in-hand only. Without a detection (``T_cam_obj`` None:
    ``status``) only the camera's own checks run."""
    eye_in_hand = calibration.mode is HandEyeMode.EYE_IN_HAND
    problems = chain_problems(
        calibration,
        T_base_flange if eye_in_hand else None,
        T_cam_obj,
        config.workspace,
        config.hand_eye.acknowledge,
        measured=config.hand_eye.camera_position,
    )
    acknowledge = calibration.settings.acknowledge
    return [
        CheckResult(
            f"plausible {problem.check}",
            "chain",
            problem.acknowledged,
            f"{problem.message} (acknowledged in {acknowledge})"
            if problem.acknowledged
            else f"{problem.message} (an unusual mount acknowledges it: {acknowledge}: "
            f"[{problem.check}])",
        )
        for problem in problems
    ]
