"""A pick's plan before anything moves: the hand-eye chain, the TCP targets, the steps of a
sequence, their pre-flight checks, and the choice among candidate detections.

Frames and units: every pose is a float64 4x4 in metres in the robot base frame unless its name
says otherwise (``T_base_tcp`` targets, ``T_base_flange`` at capture, ``T_cam_obj`` detections);
joint targets are radians. Nothing here moves the arm; the only robot I/O is the controller's
verdicts the pre-flight asks for (IK, safety limits).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from handeye_pick.calibration.files import HandEyeCalibration
from handeye_pick.cell.blend import corners, with_blends
from handeye_pick.cell.grasp import backed_off, plan_targets
from handeye_pick.cell.steps import Grip, JointMove, Move, Step
from handeye_pick.config.schema import (
    PICK_MOVES,
    PLACE_MOVES,
    CellConfig,
    PlaceConfig,
    via_move,
)
from handeye_pick.detection import Detection
from handeye_pick.errors import PlanRefused
from handeye_pick.geometry import Transform, compose, rotation_angle_between, ur_pose_list
from handeye_pick.robot.port import RobotArm
from handeye_pick.safety import (
    CheckResult,
    ControllerVerdicts,
    CornerTarget,
    JointTarget,
    PoseTarget,
    PreflightRefusal,
    chain_checks,
    preflight,
)

APPROACH, GRASP, RETREAT = PICK_MOVES
PLACE_APPROACH, PLACE, PLACE_RETREAT = PLACE_MOVES


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
        by_name = {APPROACH: self.approach, GRASP: self.grasp, RETREAT: self.retreat}
        return by_name[step]

    def targets(self) -> dict[str, Transform]:
        """The three ``T_base_tcp`` targets by step name, in the order they are moved to."""
        return {name: self.target(name) for name in PICK_MOVES}

    def targets_ur(self) -> dict[str, list[float]]:
        """The three targets as UR pose vectors (m, rad), for reports and audit records."""
        return {name: ur_pose_list(T) for name, T in self.targets().items()}


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
        Move(APPROACH, plan.approach),
        Move(GRASP, plan.grasp, slow=True),
    ]
    if grip:
        steps.append(Grip(close=True))
    steps.append(Move(RETREAT, plan.retreat))
    return steps


def place_steps(T_base_tcp_place: Transform, place: PlaceConfig, *, grip: bool) -> list[Step]:
    """Through the ``via`` poses, approach the place pose from above its tool z, put down
    (slow), release, retreat."""
    steps: list[Step] = [
        Move(via_move(pose.name), pose.T_base_tcp, fixed=True)
        for pose in place.via
        if pose.T_base_tcp is not None  # the config loader takes only TCP poses as via poses
    ]
    steps += [
        Move(PLACE_APPROACH, backed_off(T_base_tcp_place, place.approach_mm / 1000.0), fixed=True),
        Move(PLACE, T_base_tcp_place, slow=True, fixed=True),
    ]
    if grip:
        steps.append(Grip(close=False))
    steps.append(
        Move(PLACE_RETREAT, backed_off(T_base_tcp_place, place.retreat_mm / 1000.0), fixed=True)
    )
    return steps


def blended(config: CellConfig, steps: Sequence[Step], T_base_tcp_start: Transform) -> list[Step]:
    """``steps`` with their corners rounded as ``motion.blend_mm`` and ``grasp.straight_mm``
    allow (``blend.with_blends``), for a TCP standing at ``T_base_tcp_start``."""
    return with_blends(
        steps,
        T_base_tcp_start,
        config.motion.blend_mm / 1000.0,
        config.grasp.straight_mm / 1000.0,
    )


def check_steps(
    config: CellConfig,
    steps: Sequence[Step],
    arm: RobotArm,
    session_verdicts: ControllerVerdicts,
    T_base_tcp_start: Transform | None = None,
) -> list[CheckResult]:
    """Every pre-flight check on every move of ``steps`` (``safety.preflight``), and on every
    blended corner the room the TCP needs around it (which needs ``T_base_tcp_start``, where
    the sequence starts); raises ``PreflightRefusal`` listing all results when one fails.
    Verdicts on ``fixed`` targets are kept in ``session_verdicts`` (the caller clears it when
    the session restarts)."""
    poses = [PoseTarget(s.name, s.T_base_tcp, s.fixed) for s in steps if isinstance(s, Move)]
    joints = [JointTarget(s.name, s.q_rad) for s in steps if isinstance(s, JointMove)]
    rounded = (
        [
            CornerTarget(c.name, c.center_m, c.radius_m, c.extent_m)
            for c in corners(steps, T_base_tcp_start)
        ]
        if T_base_tcp_start is not None
        else []
    )
    return preflight(
        poses,
        config.motion,
        config.workspace,
        arm,
        joint_targets=joints,
        corners=rounded,
        verdicts=session_verdicts,
    )


def reached_errors(steps: Sequence[Step], reached: dict[str, Transform]) -> dict[str, StepError]:
    """Reached pose vs target for every linear move that ran."""
    return {
        step.name: step_error(step.T_base_tcp, reached[step.name])
        for step in steps
        if isinstance(step, Move) and step.name in reached
    }


def describe_plan(plan: PickPlan) -> str:
    grasp_mm = plan.grasp[:3, 3] * 1000.0
    obj_mm = plan.T_base_obj[:3, 3] * 1000.0
    return (
        f"object at [{obj_mm[0]:.1f}, {obj_mm[1]:.1f}, {obj_mm[2]:.1f}] mm in base, "
        f"grasp TCP at [{grasp_mm[0]:.1f}, {grasp_mm[1]:.1f}, {grasp_mm[2]:.1f}] mm"
    )


@dataclass(frozen=True)
class CandidateRefusal:
    """Why one candidate detection was not picked."""

    candidate: int  # its index in the request
    source: str  # the detection's source
    reasons: list[str]
    checks: list[CheckResult] = field(default_factory=list)  # every pre-flight check, if run

    @classmethod
    def of(cls, candidate: int, source: str, refusal: PreflightRefusal) -> CandidateRefusal:
        """The refusal of one candidate: the checks it failed as its reasons."""
        failed = [f"{r.target} {r.name}: {r.detail}" for r in refusal.results if not r.passed]
        return cls(candidate, source, failed, refusal.results)


class NoFeasibleCandidate(PlanRefused):
    """No candidate passed every pre-flight check; nothing moved. ``refusals`` says why each."""

    def __init__(self, refusals: list[CandidateRefusal]) -> None:
        reasons = "; ".join(
            f"candidate {r.candidate} ({r.source}): {'; '.join(r.reasons)}" for r in refusals
        )
        super().__init__(f"no candidate can be picked, nothing moved: {reasons}")
        self.refusals = refusals


@dataclass(frozen=True)
class Chosen:
    """The candidate a pick runs: its index, plan, steps and the checks they all passed."""

    index: int
    plan: PickPlan
    steps: list[Step]
    checks: list[CheckResult]


def choose(
    config: CellConfig,
    calibration: HandEyeCalibration,
    detections: Sequence[Detection],
    T_base_flange: Transform,
    T_flange_tcp: Transform,
    arm: RobotArm,
    verdicts: ControllerVerdicts,
    *,
    T_base_tcp_place: Transform | None,
    grip: bool,
    blend: bool = True,
    standoff_m: float = 0.0,
    on_plan: Callable[[PickPlan], None] | None = None,
) -> tuple[Chosen, list[CandidateRefusal]]:
    """The first candidate whose whole sequence (the pick, then the place at
    ``T_base_tcp_place`` when given) passes the chain's plausibility and every pre-flight check,
    and the refusals of those before it.

    ``T_base_flange`` (m) is the flange at acquisition; ``T_flange_tcp`` the active TCP offset;
    ``grip`` False leaves the gripper out of the steps (a touch test), ``blend`` False keeps
    every target a stop (``motion.blend_mm`` rounds the corners otherwise). Raises
    ``NoFeasibleCandidate`` when none passes, or the one candidate's own ``PreflightRefusal``
    (every check listed) when there was only one.
    """
    refusals: list[CandidateRefusal] = []
    for index, detection in enumerate(detections):
        plan = chain_plan(
            config, calibration, detection, T_base_flange, T_flange_tcp, standoff_m=standoff_m
        )
        if on_plan is not None:
            on_plan(plan)
        steps = pick_steps(plan, grip=grip)
        if T_base_tcp_place is not None and config.place is not None:
            steps += place_steps(T_base_tcp_place, config.place, grip=grip)
        T_base_tcp_start = compose(T_base_flange, T_flange_tcp)
        if blend:
            steps = blended(config, steps, T_base_tcp_start)
        plausible = chain_checks(config, calibration, detection.T_cam_obj, T_base_flange)
        try:
            if not all(check.passed for check in plausible):
                raise PreflightRefusal(plausible)  # nothing asked of the controller
            checks = plausible + check_steps(config, steps, arm, verdicts, T_base_tcp_start)
        except PreflightRefusal as refusal:
            refusals.append(CandidateRefusal.of(index, detection.source, refusal))
            continue
        return Chosen(index, plan, steps, checks), refusals
    if len(refusals) == 1:  # one detection: its own refusal says it best, every check listed
        raise PreflightRefusal(refusals[0].checks)
    raise NoFeasibleCandidate(refusals)
