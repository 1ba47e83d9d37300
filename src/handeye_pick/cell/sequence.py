"""The pieces of a cell's motion sequences: the chain, the steps, their checks, the moves, the
audit records. ``cell.Cell`` puts them in order; nothing here opens a file or a connection.

Frames and units: every pose is a float64 4x4 in metres in the robot base frame unless its name
says otherwise (``T_base_tcp`` targets, ``T_base_flange`` at capture); joint targets are radians.
Audit records carry UR pose vectors (m, rad).

The order a sequence keeps, and the point of this module: nothing moves before the cell is
ready, every target has passed every pre-flight check and the plan is on disk; the outcome
(reached poses and their errors, or the fault) is appended for every ending, Ctrl-C included
(``audited_outcome``).
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, replace

import numpy as np

from handeye_pick.audit import AuditLog
from handeye_pick.calibration.files import HandEyeCalibration
from handeye_pick.cell.grasp import backed_off, plan_targets
from handeye_pick.cell.payload import held_payload
from handeye_pick.config.schema import CellConfig, Payload, PlaceConfig
from handeye_pick.detection import Detection
from handeye_pick.errors import (
    PartDropped,
    RobotFault,
    SafetyRefusal,
    Terminated,
    ending,
)
from handeye_pick.geometry import Transform, compose, rotation_angle_between, ur_pose_list
from handeye_pick.gripper.port import GraspState, Gripper
from handeye_pick.limits import MAX_GRASP_SPEED_MPS, MAX_JOINT_SPEED_RPS, MAX_SPEED_MPS
from handeye_pick.progress import Progress
from handeye_pick.robot.port import ProgressCallback, RobotArm
from handeye_pick.safety import (
    CheckResult,
    ControllerVerdicts,
    JointTarget,
    PoseTarget,
    PreflightRefusal,
    check_motion_command,
    preflight,
)

log = logging.getLogger(__name__)

TIMEOUT_FACTOR = 1.5
"""A move may take this much longer than its trapezoid profile (speed slider, controller
ramps) before the margin from the config starts counting."""

GRASP_WATCH_PERIOD_S = 0.05
"""How often a carried part is looked at during a move (each look is a gripper round trip)."""

RETREAT = "retreat"
STEPS = ("approach", "grasp", RETREAT)
PLACE_STEPS = ("place-approach", "place", "place-retreat")


@dataclass(frozen=True)
class PickPlan:
    """Everything computed before the first motion of a pick (base frame, metres)."""

    T_flange_tcp: Transform  # active TCP offset read from the controller
    T_base_flange: Transform  # flange pose at capture (latched) or read live
    T_base_cam: Transform  # camera in base through the hand-eye calibration
    T_base_obj: Transform  # detected object in base
    approach: Transform  # T_base_tcp targets
    grasp: Transform
    retreat: Transform

    def target(self, step: str) -> Transform:
        """The ``T_base_tcp`` target of a pick step (approach, grasp, retreat)."""
        by_name = {"approach": self.approach, "grasp": self.grasp, "retreat": self.retreat}
        return by_name[step]

    def targets(self) -> dict[str, Transform]:
        """The three ``T_base_tcp`` targets by step name, in the order they are moved to."""
        return {name: self.target(name) for name in STEPS}

    def targets_ur(self) -> dict[str, list[float]]:
        """The three targets as UR pose vectors (m, rad), for reports and audit records."""
        return {name: ur_pose_list(T) for name, T in self.targets().items()}


@dataclass(frozen=True)
class Move:
    """A moveL of the TCP to ``T_base_tcp``.

    ``slow`` moves run at the grasp speed (onto the object or the place). ``fixed`` targets come
    from the config (place poses, named poses): the controller's verdict on them may be reused
    for the rest of the session.
    """

    name: str
    T_base_tcp: Transform
    slow: bool = False
    fixed: bool = False


@dataclass(frozen=True)
class JointMove:
    """A moveJ to the joint positions ``q_rad`` (rad) of a named pose from the config."""

    name: str
    q_rad: tuple[float, ...]


@dataclass(frozen=True)
class Grip:
    """Work the gripper: ``close`` grasps (then confirms), otherwise releases."""

    close: bool

    @property
    def name(self) -> str:
        return "gripper close" if self.close else "gripper open"


Step = Move | JointMove | Grip


@dataclass(frozen=True)
class StepError:
    """How far a reached TCP pose is from its target."""

    position_mm: float
    rotation_deg: float


def step_error(T_target: Transform, T_reached: Transform) -> StepError:
    return StepError(
        position_mm=float(np.linalg.norm(T_reached[:3, 3] - T_target[:3, 3])) * 1000.0,
        rotation_deg=math.degrees(rotation_angle_between(T_target[:3, :3], T_reached[:3, :3])),
    )


def trapezoid_s(distance: float, speed: float, accel: float) -> float:
    """Duration of a trapezoid (or triangle) velocity profile over ``distance`` (any unit)."""
    if distance >= speed**2 / accel:
        return distance / speed + speed / accel
    return 2.0 * math.sqrt(distance / accel)


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
    return trapezoid_s(distance, speed_mps, accel_mps2) * TIMEOUT_FACTOR + margin_s


def joint_move_timeout_s(
    q_from: Sequence[float],
    q_to: Sequence[float],
    speed_rps: float,
    accel_rps2: float,
    margin_s: float,
) -> float:
    """Upper bound for a moveJ, as ``move_timeout_s`` over the largest joint travel (rad)."""
    distance = max(abs(b - a) for a, b in zip(q_from, q_to, strict=True))
    return trapezoid_s(distance, speed_rps, accel_rps2) * TIMEOUT_FACTOR + margin_s


# --- planning -----------------------------------------------------------------------------------


def chain_plan(
    config: CellConfig,
    calibration: HandEyeCalibration,
    detection: Detection,
    T_base_flange: Transform,
    T_flange_tcp: Transform,
    *,
    standoff_m: float = 0.0,
) -> PickPlan:
    """The hand-eye chain and the TCP targets for the flange pose at capture; no robot I/O.

    ``T_base_obj = T_base_cam @ T_cam_obj``; eye-in-hand ``T_base_cam = T_base_flange @
    T_flange_cam``. A position-only detection keeps the yaw of the TCP at capture
    (``T_base_flange @ T_flange_tcp``). ``standoff_m`` holds the grasp target that far back
    along its tool z (the touch test stops short of the point).
    """
    T_base_cam = calibration.T_base_cam(T_base_flange)
    T_base_obj = compose(T_base_cam, detection.T_cam_obj)
    targets = plan_targets(
        T_base_obj, compose(T_base_flange, T_flange_tcp), config.grasp, detection.position_only
    )
    if standoff_m > 0.0:
        targets = replace(targets, grasp=backed_off(targets.grasp, standoff_m))
    return PickPlan(
        T_flange_tcp,
        T_base_flange,
        T_base_cam,
        T_base_obj,
        targets.approach,
        targets.grasp,
        targets.retreat,
    )


def pick_steps(plan: PickPlan, *, grip: bool) -> list[Step]:
    """Approach, grasp (slow), the gripper closing when ``grip``, retreat."""
    steps: list[Step] = [
        Move("approach", plan.approach),
        Move("grasp", plan.grasp, slow=True),
    ]
    if grip:
        steps.append(Grip(close=True))
    steps.append(Move(RETREAT, plan.retreat))
    return steps


def place_steps(T_base_tcp_place: Transform, place: PlaceConfig, *, grip: bool) -> list[Step]:
    """Approach the place pose from above its tool z, put down (slow), release, retreat."""
    steps: list[Step] = [
        Move(
            "place-approach", backed_off(T_base_tcp_place, place.approach_mm / 1000.0), fixed=True
        ),
        Move("place", T_base_tcp_place, slow=True, fixed=True),
    ]
    if grip:
        steps.append(Grip(close=False))
    steps.append(
        Move("place-retreat", backed_off(T_base_tcp_place, place.retreat_mm / 1000.0), fixed=True)
    )
    return steps


def check_steps(
    config: CellConfig, steps: Sequence[Step], arm: RobotArm, session_verdicts: ControllerVerdicts
) -> list[CheckResult]:
    """Every pre-flight check on every move of ``steps`` (``safety.preflight``); raises
    ``PreflightRefusal`` listing all results when one fails. Verdicts on ``fixed`` targets are
    kept in ``session_verdicts`` (the caller clears it when the session restarts)."""
    poses = [PoseTarget(s.name, s.T_base_tcp, s.fixed) for s in steps if isinstance(s, Move)]
    joints = [JointTarget(s.name, s.q_rad) for s in steps if isinstance(s, JointMove)]
    return preflight(
        poses, config.motion, config.workspace, arm, joint_targets=joints, verdicts=session_verdicts
    )


# --- moving -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Executed:
    """What ``execute`` did: the reached ``T_base_tcp`` per move name, and the grasp as the
    gripper sensed it when it closed (None: no gripper closed)."""

    reached: dict[str, Transform]
    grasp: GraspState | None = None


def execute(
    config: CellConfig,
    steps: Sequence[Step],
    arm: RobotArm,
    progress: Progress,
    outcome: dict[str, object],
    before_move: Callable[[str], None] | None = None,
    gripper: Gripper | None = None,
    holding: GraspState | None = None,
) -> Executed:
    """Run ``steps`` in order.

    ``outcome["step"]`` names the step running (kept when one fails, removed at the end) and
    ``outcome["reached"]`` fills as moves end, so the audit says how far a sequence got;
    ``outcome["gripper"]`` lists the gripper's commands, their sensed states and the payloads
    set. ``before_move`` is called with a move's name right before it is sent (an operator's
    confirmation). Every command's speed is capped again here, whatever the config said.

    The gripper: a missed grasp opens the gripper, runs the retreat and ends the sequence there
    (``Executed.grasp`` says so). A held part (confirmed or unconfirmed) gets the object payload
    before the next move, the empty tool's after its release. While a confirmed part is carried,
    every move watches it; a lost part raises ``PartDropped`` (the adapter stops the arm).
    ``holding`` is the grasp of a part already held when the sequence starts (a pick that did
    not place it), watched the same way.
    """
    motion = config.motion
    reached: dict[str, Transform] = {}
    reached_ur: dict[str, list[float]] = {}
    outcome["reached"] = reached_ur
    commands: list[dict[str, object]] = []
    if gripper is not None:
        outcome["gripper"] = {"kind": gripper.kind, "commands": commands}
    grasp = holding
    last_move: str | None = None  # a missed grasp ends the sequence after this move
    T_base_tcp_from: Transform | None = None
    for step in steps:
        outcome["step"] = step.name
        if isinstance(step, Grip):
            if gripper is None:
                continue
            if step.close:
                grasp = _close(gripper, progress, commands)
                if grasp is GraspState.MISSED:
                    _release(gripper, progress, commands)
                    last_move = RETREAT
                else:
                    _set_payload(arm, _object_payload(config), "part", progress, commands)
            else:
                _release(gripper, progress, commands)
                grasp = None
                _set_payload(arm, config.robot.tool_payload, "empty tool", progress, commands)
            continue
        if before_move is not None:
            before_move(step.name)
        watched = gripper if grasp is GraspState.CONFIRMED else None
        if isinstance(step, JointMove):
            _check_joint_command(motion.joint_speed_rps)
            timeout_s = joint_move_timeout_s(
                arm.joint_positions(),
                step.q_rad,
                motion.joint_speed_rps,
                motion.joint_accel_rps2,
                motion.timeout_margin_s,
            )
            with progress.step(step.name) as report:
                reached[step.name] = arm.move_joints(
                    step.q_rad,
                    motion.joint_speed_rps,
                    motion.joint_accel_rps2,
                    timeout_s,
                    _watching(report, watched, step.name),
                )
            T_base_tcp_from = reached[step.name]
        else:
            speed_mps, cap_mps = (
                (motion.grasp_speed_mps, MAX_GRASP_SPEED_MPS)
                if step.slow
                else (motion.speed_mps, MAX_SPEED_MPS)
            )
            check_motion_command(speed_mps, motion.accel_mps2, max_speed_mps=cap_mps)
            if T_base_tcp_from is None:
                T_base_tcp_from = arm.tcp_pose()
            timeout_s = move_timeout_s(
                T_base_tcp_from,
                step.T_base_tcp,
                speed_mps,
                motion.accel_mps2,
                motion.timeout_margin_s,
            )
            with progress.step(step.name) as report:
                reached[step.name] = arm.move_linear(
                    step.T_base_tcp,
                    speed_mps,
                    motion.accel_mps2,
                    timeout_s,
                    _watching(report, watched, step.name),
                )
            T_base_tcp_from = step.T_base_tcp
        reached_ur[step.name] = ur_pose_list(reached[step.name])
        if step.name == last_move:
            break
    del outcome["step"]
    return Executed(reached, grasp)


def _close(gripper: Gripper, progress: Progress, commands: list[dict[str, object]]) -> GraspState:
    with progress.step(f"gripper close ({gripper.kind})"):
        grasp = gripper.close()
    commands.append({"command": "close", "grasp": grasp.value})
    progress.say(f"grasp {grasp.value}")
    return grasp


def _release(gripper: Gripper, progress: Progress, commands: list[dict[str, object]]) -> None:
    with progress.step(f"gripper open ({gripper.kind})"):
        sensed = gripper.open()
    commands.append({"command": "open", "release": "confirmed" if sensed else "unconfirmed"})


def _object_payload(config: CellConfig) -> Payload | None:
    """The tool holding the configured part (None: no part configured, payload left alone)."""
    tool, part = config.robot.tool_payload, config.object
    if tool is None or part is None:  # the config loader requires the tool's with the part's
        return None
    return held_payload(tool, part, config.robot.T_flange_tcp)


def _set_payload(
    arm: RobotArm,
    payload: Payload | None,
    what: str,
    progress: Progress,
    commands: list[dict[str, object]],
) -> None:
    if payload is None:
        return
    with progress.step(f"payload {payload.mass_kg:g} kg ({what})"):
        arm.set_payload(payload.mass_kg, payload.cog_flange_m)
    commands.append(
        {
            "command": "set_payload",
            "payload": what,
            "mass_kg": payload.mass_kg,
            "cog_flange_m": list(payload.cog_flange_m),
        }
    )


def _watching(report: ProgressCallback, gripper: Gripper | None, move: str) -> ProgressCallback:
    """``report``, and while ``gripper`` holds a confirmed part, a look at it every
    ``GRASP_WATCH_PERIOD_S`` and when the move ends: a lost part raises ``PartDropped`` (the
    adapter stops the arm for any exception from its progress callback)."""
    if gripper is None:
        return report
    last_look = -math.inf

    def watch(fraction: float) -> None:
        nonlocal last_look
        report(fraction)
        now = time.monotonic()
        if fraction < 1.0 and now - last_look < GRASP_WATCH_PERIOD_S:
            return
        last_look = now
        if gripper.state() is not GraspState.CONFIRMED:
            raise PartDropped(
                f"{move}: the {gripper.kind} gripper lost the part at {fraction:.0%} of the "
                "move: the arm was stopped; clear the part, then resume"
            )

    return watch


def _check_joint_command(speed_rps: float) -> None:
    if not 0.0 < speed_rps <= MAX_JOINT_SPEED_RPS:
        raise SafetyRefusal(
            f"motion command refused, nothing sent: joint speed {speed_rps:g} rad/s outside "
            f"(0, {MAX_JOINT_SPEED_RPS:g}] rad/s"
        )


def reached_errors(steps: Sequence[Step], reached: dict[str, Transform]) -> dict[str, StepError]:
    """Reached pose vs target for every linear move that ran."""
    return {
        step.name: step_error(step.T_base_tcp, reached[step.name])
        for step in steps
        if isinstance(step, Move) and step.name in reached
    }


# --- audit --------------------------------------------------------------------------------------


def failure_fields(exc: BaseException) -> dict[str, object]:
    """``status`` (``errors.ending``) and ``error`` of an outcome record for the exception that
    ended a sequence."""
    status = ending(exc).outcome
    if isinstance(exc, KeyboardInterrupt):
        signal_name = "SIGTERM" if isinstance(exc, Terminated) else "SIGINT"
        return {"status": status, "error": {"type": type(exc).__name__, "signal": signal_name}}
    error: dict[str, object] = {"type": type(exc).__name__, "message": str(exc)}
    if isinstance(exc, RobotFault):
        error.update(
            safety_mode=exc.safety_mode, runtime_state=exc.runtime_state, robot_mode=exc.robot_mode
        )
    if isinstance(exc, PreflightRefusal):
        error["checks"] = [asdict(check) for check in exc.results]
    return {"status": status, "error": error}


@contextmanager
def audited_outcome(audit: AuditLog, outcome: dict[str, object]) -> Iterator[dict[str, object]]:
    """Append ``outcome`` when the block ends, however it ends.

    The block fills ``outcome`` (``status`` at least) as it goes; when it raises, the failure's
    ``status`` and ``error`` are added and the record is appended before the error propagates
    (a failing append is logged and does not hide that error).
    """
    try:
        yield outcome
    except BaseException as exc:
        append_failure(audit, outcome, exc)
        raise
    audit.append(outcome)


def append_failure(audit: AuditLog, outcome: dict[str, object], exc: BaseException) -> None:
    """Append ``outcome`` with the failure's fields while ``exc`` propagates: a failing append
    is logged and must not hide ``exc``."""
    outcome.update(failure_fields(exc))
    try:
        audit.append(outcome)
    except Exception:
        log.exception("could not append the outcome to the audit log: %s", outcome)


def plan_record(
    config: CellConfig,
    calibration: HandEyeCalibration,
    detection: Detection,
    plan: PickPlan,
    flange_pose_source: str,
) -> dict[str, object]:
    """The plan part of a pick's audit record: inputs, calibration, chain, pick targets."""
    motion = config.motion
    return {
        "config": str(config.path),
        "host": config.robot.host,
        "detection": {
            "source": detection.source,
            "position_only": detection.position_only,
            "T_cam_obj": plan_matrix(detection.T_cam_obj),
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
        "flange_pose_source": flange_pose_source,
        "T_base_cam": plan_matrix(plan.T_base_cam),
        "T_base_obj": plan_matrix(plan.T_base_obj),
        "motion": {
            "speed_mps": motion.speed_mps,
            "grasp_speed_mps": motion.grasp_speed_mps,
            "accel_mps2": motion.accel_mps2,
        },
    }


def steps_record(steps: Sequence[Step]) -> dict[str, object]:
    """Every move's target (UR vector, m and rad, or joints in rad) in order, for the audit."""
    return {
        step.name: ur_pose_list(step.T_base_tcp) if isinstance(step, Move) else list(step.q_rad)
        for step in steps
        if not isinstance(step, Grip)
    }


def describe_plan(plan: PickPlan) -> str:
    grasp_mm = plan.grasp[:3, 3] * 1000.0
    obj_mm = plan.T_base_obj[:3, 3] * 1000.0
    return (
        f"object at [{obj_mm[0]:.1f}, {obj_mm[1]:.1f}, {obj_mm[2]:.1f}] mm in base, "
        f"grasp TCP at [{grasp_mm[0]:.1f}, {grasp_mm[1]:.1f}, {grasp_mm[2]:.1f}] mm"
    )


def plan_matrix(T: Transform) -> list[list[float]]:
    return [[float(v) for v in row] for row in T]
