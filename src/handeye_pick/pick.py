"""The pick sequence: check the cell, plan, pre-flight, audit, then approach, grasp, retreat.

No file or network I/O of its own: the caller loads the config, calibration and detection,
connects the arm and opens the audit log. Every pose is a float64 4x4 in metres in the robot base
frame unless its name says otherwise; audit records carry UR pose vectors (m, rad).

Order matters and is the point of this module: nothing moves before the cell is ready, every
target has passed every pre-flight check, and the plan is on disk. Afterwards the outcome (reached
poses and their errors, or the fault) is appended for every ending, including Ctrl-C.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from typing import TypeVar

import numpy as np

from handeye_pick.audit import AuditLog
from handeye_pick.calibration import HandEyeCalibration
from handeye_pick.config import CellConfig
from handeye_pick.detection import Detection
from handeye_pick.errors import RobotError, RobotFault, SafetyRefusal
from handeye_pick.geometry import (
    Transform,
    compose,
    rotation_angle_between,
    ur_pose_list,
)
from handeye_pick.grasp import PickTargets, backed_off, plan_targets
from handeye_pick.limits import MAX_GRASP_SPEED_MPS, MAX_SPEED_MPS
from handeye_pick.progress import Progress
from handeye_pick.robot.port import RobotArm
from handeye_pick.safety import (
    CheckResult,
    PreflightRefusal,
    cell_readiness_problems,
    check_motion_command,
    preflight,
)

log = logging.getLogger(__name__)

TIMEOUT_FACTOR = 1.5
"""A move may take this much longer than its trapezoid profile (speed slider, controller
ramps) before the margin from the config starts counting."""

STEPS = ("approach", "grasp", "retreat")

ArmT = TypeVar("ArmT")


@dataclass(frozen=True)
class PickPlan:
    """Everything computed before the first motion (base frame, metres)."""

    T_flange_tcp: Transform  # active TCP offset read from the controller
    T_base_flange: Transform  # flange pose from a fresh RTDE sample
    T_base_cam: Transform  # camera in base through the hand-eye calibration
    T_base_obj: Transform  # detected object in base
    targets: PickTargets  # T_base_tcp for approach, grasp, retreat


@dataclass(frozen=True)
class StepError:
    """How far a reached TCP pose is from its target."""

    position_mm: float
    rotation_deg: float


@dataclass(frozen=True)
class PickResult:
    """A pick that ran to the end (or a dry run: nothing reached)."""

    plan: PickPlan
    checks: list[CheckResult]
    dry_run: bool
    reached: dict[str, Transform] = field(default_factory=dict)  # step name -> T_base_tcp

    def errors(self) -> dict[str, StepError]:
        """Reached pose vs target for every step that ran."""
        return {
            name: step_error(target_of(self.plan.targets, name), T_reached)
            for name, T_reached in self.reached.items()
        }


def target_of(targets: PickTargets, step: str) -> Transform:
    """The ``T_base_tcp`` target of a step name (approach, grasp, retreat)."""
    by_name = {"approach": targets.approach, "grasp": targets.grasp, "retreat": targets.retreat}
    return by_name[step]


def step_error(T_target: Transform, T_reached: Transform) -> StepError:
    return StepError(
        position_mm=float(np.linalg.norm(T_reached[:3, 3] - T_target[:3, 3])) * 1000.0,
        rotation_deg=math.degrees(rotation_angle_between(T_target[:3, :3], T_reached[:3, :3])),
    )


def move_timeout_s(
    T_from: Transform, T_to: Transform, speed_mps: float, accel_mps2: float, margin_s: float
) -> float:
    """Upper bound for a moveL: its trapezoid time times ``TIMEOUT_FACTOR`` plus ``margin_s``.

    The path length is the larger of the translation (m) and the rotation (rad, as if turning at
    ``speed_mps`` rad/s), so a move that mostly turns the tool still gets enough time.
    """
    distance = max(
        float(np.linalg.norm(T_to[:3, 3] - T_from[:3, 3])),
        rotation_angle_between(T_from[:3, :3], T_to[:3, :3]),
    )
    if distance >= speed_mps**2 / accel_mps2:
        duration = distance / speed_mps + speed_mps / accel_mps2
    else:
        duration = 2.0 * math.sqrt(distance / accel_mps2)
    return duration * TIMEOUT_FACTOR + margin_s


def plan_pick(
    config: CellConfig,
    calibration: HandEyeCalibration,
    detection: Detection,
    arm: RobotArm,
    *,
    standoff_m: float = 0.0,
) -> PickPlan:
    """Refuse an unready cell, read the robot, and chain the detection into TCP targets.

    Raises ``SafetyRefusal`` listing every readiness problem (remote control, stops, TCP offset
    differing from the config). The chain itself is ``chain_plan`` with the flange read now.
    """
    robot = config.robot
    T_flange_tcp = arm.tcp_offset()
    problems = cell_readiness_problems(
        arm.status(),
        T_flange_tcp,
        robot.T_flange_tcp,
        tolerance_mm=robot.tcp_offset_tolerance_mm,
        tolerance_deg=robot.tcp_offset_tolerance_deg,
    )
    if problems:
        raise SafetyRefusal(f"cell on {robot.host} is not ready: " + "; ".join(problems))
    return chain_plan(
        config, calibration, detection, arm.flange_pose(), T_flange_tcp, standoff_m=standoff_m
    )


def chain_plan(
    config: CellConfig,
    calibration: HandEyeCalibration,
    detection: Detection,
    T_base_flange: Transform,
    T_flange_tcp: Transform,
    *,
    standoff_m: float = 0.0,
) -> PickPlan:
    """The hand-eye chain and the TCP targets for a given flange pose; no robot I/O.

    ``T_base_obj = T_base_cam @ T_cam_obj``; eye-in-hand ``T_base_cam = T_base_flange @
    T_flange_cam``. ``standoff_m`` holds the grasp target that far back along its tool z (the
    touch test stops short of the point); approach and retreat stay where the grasp config puts
    them.
    """
    T_base_cam = calibration.T_base_cam(T_base_flange)
    T_base_obj = compose(T_base_cam, detection.T_cam_obj)
    targets = plan_targets(
        T_base_obj, compose(T_base_flange, T_flange_tcp), config.grasp, detection.position_only
    )
    if standoff_m > 0.0:
        targets = replace(targets, grasp=backed_off(targets.grasp, standoff_m))
    return PickPlan(T_flange_tcp, T_base_flange, T_base_cam, T_base_obj, targets)


def run_pick(
    config: CellConfig,
    calibration: HandEyeCalibration,
    detection: Detection,
    arm: RobotArm,
    audit: AuditLog,
    *,
    dry_run: bool,
    progress: Progress,
    on_plan: Callable[[PickPlan], None] | None = None,
    before_move: Callable[[str], None] | None = None,
    standoff_m: float = 0.0,
) -> PickResult:
    """Plan, check, audit and (unless ``dry_run``) run approach, grasp, retreat.

    ``on_plan`` is called with the plan as soon as it exists (before the pre-flight checks), so a
    caller can report it even when the pick is refused or fails later. ``before_move`` is called
    with the step name right before each move (an operator's confirmation); ``standoff_m`` as in
    ``chain_plan``. Raises ``SafetyRefusal``
    (nothing moved), ``RobotError`` (fault during the pick) or ``KeyboardInterrupt`` (after
    stopL); an outcome record is appended to ``audit`` in every case.
    """
    outcome: dict[str, object] = {"event": "outcome", "dry_run": dry_run, "reached": {}}
    try:
        plan = plan_pick(config, calibration, detection, arm, standoff_m=standoff_m)
        if on_plan is not None:
            on_plan(plan)
        progress.say("planned: " + _describe_plan(plan))
        # Until the plan record is written, a refusal's outcome says what was refused.
        outcome["flange_pose"] = ur_pose_list(plan.T_base_flange)
        outcome["targets"] = {name: ur_pose_list(target_of(plan.targets, name)) for name in STEPS}
        checks = _checked(config, plan, arm)
        progress.say(f"pre-flight: {len(checks)} checks passed")
        audit.append(_plan_record(config, calibration, detection, plan, checks, dry_run))
        del outcome["flange_pose"], outcome["targets"]
        result = PickResult(plan, checks, dry_run)
        if not dry_run:
            _move(config, plan, arm, progress, result.reached, outcome, before_move)
    except BaseException as exc:
        outcome.update(_failure_fields(exc))
        if isinstance(exc, PreflightRefusal):
            outcome["checks"] = [asdict(check) for check in exc.results]
        _append_outcome_keeping_error(audit, outcome)
        raise
    outcome["status"] = "dry-run" if dry_run else "done"
    outcome["errors"] = {name: asdict(error) for name, error in result.errors().items()}
    audit.append(outcome)
    return result


def connect_audited(audit: AuditLog, connect: Callable[[], ArmT], *, dry_run: bool) -> ArmT:
    """``connect()``; when it fails (connection refused or lost, cell refusing the control
    program, Ctrl-C) an outcome record is appended before the error propagates, so a pick that
    never reached ``run_pick`` is on disk too."""
    try:
        return connect()
    except BaseException as exc:
        outcome: dict[str, object] = {
            "event": "outcome",
            "dry_run": dry_run,
            "step": "connect",
            "reached": {},
        }
        outcome.update(_failure_fields(exc))
        _append_outcome_keeping_error(audit, outcome)
        raise


def _checked(config: CellConfig, plan: PickPlan, arm: RobotArm) -> list[CheckResult]:
    targets = {name: target_of(plan.targets, name) for name in STEPS}
    return preflight(targets, config.motion, config.workspace, arm)


def _move(
    config: CellConfig,
    plan: PickPlan,
    arm: RobotArm,
    progress: Progress,
    reached: dict[str, Transform],
    outcome: dict[str, object],
    before_move: Callable[[str], None] | None,
) -> None:
    """The three moves and the gripper; ``reached`` and ``outcome`` are filled as they happen."""
    motion, gripper = config.motion, config.robot.gripper
    T_base_tcp_from = compose(plan.T_base_flange, plan.T_flange_tcp)  # TCP where the plan was read
    reached_ur: dict[str, list[float]] = {}
    outcome["reached"] = reached_ur
    for name in STEPS:
        if name == "retreat" and gripper is not None:
            outcome["step"] = "gripper"
            with progress.step(f"gripper {gripper.bank.value} output {gripper.index}"):
                arm.set_digital_output(gripper.bank, gripper.index, gripper.close_value)
                time.sleep(gripper.settle_s)
        outcome["step"] = name
        T_base_tcp_to = target_of(plan.targets, name)
        speed_mps, cap_mps = (
            (motion.grasp_speed_mps, MAX_GRASP_SPEED_MPS)
            if name == "grasp"
            else (motion.speed_mps, MAX_SPEED_MPS)
        )
        check_motion_command(speed_mps, motion.accel_mps2, max_speed_mps=cap_mps)
        timeout_s = move_timeout_s(
            T_base_tcp_from, T_base_tcp_to, speed_mps, motion.accel_mps2, motion.timeout_margin_s
        )
        if before_move is not None:
            before_move(name)
        with progress.step(name) as report:
            reached[name] = arm.move_linear(
                T_base_tcp_to, speed_mps, motion.accel_mps2, timeout_s, report
            )
        reached_ur[name] = ur_pose_list(reached[name])
        T_base_tcp_from = T_base_tcp_to
    del outcome["step"]


def _failure_fields(exc: BaseException) -> dict[str, object]:
    if isinstance(exc, KeyboardInterrupt):
        return {"status": "interrupted", "error": {"type": "KeyboardInterrupt"}}
    error: dict[str, object] = {"type": type(exc).__name__, "message": str(exc)}
    if isinstance(exc, RobotFault):
        error.update(
            safety_mode=exc.safety_mode, runtime_state=exc.runtime_state, robot_mode=exc.robot_mode
        )
    if isinstance(exc, SafetyRefusal):
        status = "refused"
    elif isinstance(exc, RobotError):
        status = "fault"
    else:
        status = "error"
    return {"status": status, "error": error}


def _append_outcome_keeping_error(audit: AuditLog, outcome: dict[str, object]) -> None:
    """Append the outcome while another error propagates: a failing audit must not hide it."""
    try:
        audit.append(outcome)
    except Exception:
        log.exception("could not append the pick outcome to the audit log: %s", outcome)


def _plan_record(
    config: CellConfig,
    calibration: HandEyeCalibration,
    detection: Detection,
    plan: PickPlan,
    checks: list[CheckResult],
    dry_run: bool,
) -> dict[str, object]:
    motion = config.motion
    return {
        "event": "plan",
        "dry_run": dry_run,
        "config": str(config.path),
        "host": config.robot.host,
        "detection": {
            "source": detection.source,
            "position_only": detection.position_only,
            "T_cam_obj": _matrix(detection.T_cam_obj),
        },
        "calibration": {
            "file": str(calibration.path),
            "sha256": calibration.sha256,
            "mode": calibration.mode.value,
            "units": calibration.units,
            "inverted": calibration.inverted,
        },
        "tcp_offset": ur_pose_list(plan.T_flange_tcp),
        "flange_pose": ur_pose_list(plan.T_base_flange),
        "T_base_cam": _matrix(plan.T_base_cam),
        "T_base_obj": _matrix(plan.T_base_obj),
        "targets": {name: ur_pose_list(target_of(plan.targets, name)) for name in STEPS},
        "motion": {
            "speed_mps": motion.speed_mps,
            "grasp_speed_mps": motion.grasp_speed_mps,
            "accel_mps2": motion.accel_mps2,
        },
        "checks": [asdict(check) for check in checks],
    }


def _describe_plan(plan: PickPlan) -> str:
    grasp_mm = plan.targets.grasp[:3, 3] * 1000.0
    obj_mm = plan.T_base_obj[:3, 3] * 1000.0
    return (
        f"object at [{obj_mm[0]:.1f}, {obj_mm[1]:.1f}, {obj_mm[2]:.1f}] mm in base, "
        f"grasp TCP at [{grasp_mm[0]:.1f}, {grasp_mm[1]:.1f}, {grasp_mm[2]:.1f}] mm"
    )


def _matrix(T: Transform) -> list[list[float]]:
    return [[float(v) for v in row] for row in T]
