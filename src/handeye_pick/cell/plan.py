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
from typing import TYPE_CHECKING

import numpy as np

from handeye_pick.cell.blend import corners, with_blends
from handeye_pick.cell.grasp import backed_off, plan_targets
from handeye_pick.cell.stretch import Stretch, paying_blends
from handeye_pick.config.schema import (
    PICK_MOVES,
    PLACE_MOVES,
    CellConfig,
    GraspConfig,
    PlaceConfig,
    SceneConfig,
    via_move,
)
from handeye_pick.detection import Detection
from handeye_pick.errors import PlanRefused
from handeye_pick.geometry import Transform, compose, rotation_angle_between, ur_pose_list
from handeye_pick.hand_eye.files import HandEyeCalibration
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
from handeye_pick.scene import alternatives
from handeye_pick.steps import Grip, JointMove, Move, Step

if TYPE_CHECKING:
    from handeye_pick.scene.check import SceneCheck

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


def blended(
    config: CellConfig, steps: Sequence[Step], T_base_tcp_start: Transform, path_start_s: float
) -> list[Step]:
    """``steps`` with their corners rounded as ``motion.blend_mm`` and ``grasp.straight_mm``
    allow (``blend.with_blends``), for a TCP standing at ``T_base_tcp_start``, kept only in the
    stretches where they save more than a path start costs (``path_start_s``, s;
    ``stretch.paying_blends``)."""
    return blended_stretches(config, steps, T_base_tcp_start, path_start_s)[0]


def blended_stretches(
    config: CellConfig, steps: Sequence[Step], T_base_tcp_start: Transform, path_start_s: float
) -> tuple[list[Step], list[Stretch]]:
    """``blended``'s steps and the choice it made for each stretch of corners."""
    rounded = with_blends(
        steps,
        T_base_tcp_start,
        config.motion.blend_mm / 1000.0,
        config.grasp.straight_mm / 1000.0,
    )
    return paying_blends(rounded, T_base_tcp_start, config.motion, path_start_s)


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


def with_scene_checks(
    config: CellConfig,
    steps: Sequence[Step],
    T_base_tcp_start: Transform,
    T_flange_tcp: Transform,
    checks: list[CheckResult],
    q_actual: Sequence[float] | None = None,
) -> list[CheckResult]:
    """``checks`` of a sequence of configured targets and, with a scene, the sweep of the tool
    and the arm (from the controller's actual joints ``q_actual``, rad) along it from
    ``T_base_tcp_start`` (``scene.check.SceneCheck.check_tool``); raises
    ``PreflightRefusal`` listing them all when a collision check fails."""
    if config.scene is None:
        return checks
    from handeye_pick.scene.check import SceneCheck

    scene = SceneCheck(config.scene, config.tool_shape, T_flange_tcp, config.robot.model)
    results = checks + scene.check_tool(steps, T_base_tcp_start, q_actual)
    if not all(r.passed for r in results):
        raise PreflightRefusal(results)
    return results


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
    def of(cls, candidate: int, source: str, results: Sequence[CheckResult]) -> CandidateRefusal:
        """The refusal of one candidate: the checks it failed as its reasons."""
        return cls(candidate, source, _failed(results), list(results))


class NoFeasibleCandidate(PlanRefused):
    """No candidate passed every pre-flight check; nothing moved. ``refusals`` says why each;
    ``note`` as for ``PreflightRefusal``."""

    def __init__(self, refusals: list[CandidateRefusal], note: str = "") -> None:
        reasons = "; ".join(
            f"candidate {r.candidate} ({r.source}): {'; '.join(r.reasons)}" for r in refusals
        )
        super().__init__(
            f"no candidate can be picked, nothing moved: {reasons}{'; ' + note if note else ''}"
        )
        self.refusals = refusals


@dataclass(frozen=True)
class AlternativeOutcome:
    """A grasp alternative of the chosen candidate (docs/scene.md): its turn and tilt, how far
    it turns the wrist from the TCP at capture, and why it was not taken (empty: taken)."""

    yaw_deg: float
    tilt_deg: float
    wrist_turn_deg: float
    reasons: list[str]


@dataclass(frozen=True)
class Chosen:
    """The candidate a pick runs: its index, plan, steps and the checks they all passed; with
    a scene, the grasp alternative taken and those that were not."""

    index: int
    plan: PickPlan
    steps: list[Step]
    checks: list[CheckResult]
    alternative: AlternativeOutcome | None = None  # None: no scene, the detected grasp
    others: list[AlternativeOutcome] = field(default_factory=list)

    def alternative_fields(self) -> dict[str, object] | None:
        """The grasp alternative taken and why the others were not, as the reply, the
        ``--json`` report and the audit's plan record carry it; None without a scene."""
        if self.alternative is None:
            return None
        taken = self.alternative
        return {
            "yaw_deg": round(taken.yaw_deg, 3),
            "tilt_deg": round(taken.tilt_deg, 3),
            "wrist_turn_deg": round(taken.wrist_turn_deg, 3),
            "others": [
                {
                    "yaw_deg": round(o.yaw_deg, 3),
                    "tilt_deg": round(o.tilt_deg, 3),
                    "wrist_turn_deg": round(o.wrist_turn_deg, 3),
                    "reasons": o.reasons,
                }
                for o in self.others
            ],
        }

    def alternative_record(self) -> dict[str, object]:
        """``{"alternative": ...}`` for the plan record; empty without a scene (as before)."""
        fields = self.alternative_fields()
        return {} if fields is None else {"alternative": fields}


def _failed(results: Sequence[CheckResult]) -> list[str]:
    return [r.line for r in results if not r.passed]


@dataclass(frozen=True)
class _Trial:
    """What ``choose`` needs to try one candidate."""

    config: CellConfig
    arm: RobotArm
    verdicts: ControllerVerdicts
    T_base_tcp_start: Transform
    T_base_tcp_place: Transform | None
    grip: bool
    blend: bool
    scene: SceneCheck | None
    q_actual: tuple[float, ...] | None  # the controller's joints (rad) when the arm is checked
    path_start_s: float  # what a path start costs on this controller (s)

    def sequence(self, plan: PickPlan) -> list[Step]:
        """The pick of ``plan`` and, when the cell places, its place; corners blended."""
        steps = pick_steps(plan, grip=self.grip)
        if self.T_base_tcp_place is not None and self.config.place is not None:
            steps += place_steps(self.T_base_tcp_place, self.config.place, grip=self.grip)
        if self.blend:
            steps = blended(self.config, steps, self.T_base_tcp_start, self.path_start_s)
        return steps

    def preflight(self, steps: Sequence[Step]) -> list[CheckResult]:
        return check_steps(self.config, steps, self.arm, self.verdicts, self.T_base_tcp_start)


def _with_grasp(plan: PickPlan, T_base_tcp_grasp: Transform, grasp: GraspConfig) -> PickPlan:
    """``plan`` with another grasp target, its approach and retreat backed off along it."""
    return replace(
        plan,
        approach=backed_off(T_base_tcp_grasp, grasp.approach_mm / 1000.0),
        grasp=T_base_tcp_grasp,
        retreat=backed_off(T_base_tcp_grasp, grasp.retreat_mm / 1000.0),
    )


def _relabelled(results: Sequence[CheckResult], label: str) -> list[CheckResult]:
    return [replace(r, target=f"{r.target} ({label})") for r in results]


def _try_alternatives(
    trial: _Trial, scene: SceneCheck, index: int, detection: Detection, plan: PickPlan
) -> tuple[Chosen | None, list[CheckResult]]:
    """The grasp alternatives of one candidate in their order (``scene.alternatives``): the
    first tier with one passing every check gives the one that turns the wrist least; else
    None and every alternative's results, each target labelled with its alternative."""
    config = trial.config
    grasp = config.grasp
    part_size = detection.size_mm if detection.size_mm is not None else grasp.part_size_mm
    tiers = alternatives.tiers(
        plan.T_base_obj,
        plan.grasp,
        detection.symmetry,
        config.scene or SceneConfig(),
        grasp.tilt_max_deg,
        grasp.symmetry_step_deg,
    )
    R_start = trial.T_base_tcp_start[:3, :3]
    labelled = sum(len(tier) for tier in tiers) > 1  # one alternative: the detected grasp
    others: list[AlternativeOutcome] = []
    results: list[CheckResult] = []
    for tier in tiers:
        passing = []
        for alt in tier:
            turn = math.degrees(rotation_angle_between(R_start, alt.T_base_tcp[:3, :3]))
            alt_plan = _with_grasp(plan, alt.T_base_tcp, grasp)
            early = scene.descent_refusal(alt_plan.approach, alt.T_base_tcp)
            if early is not None:  # the tool at the grasp is in the way: no sequence to build
                others.append(AlternativeOutcome(alt.yaw_deg, alt.tilt_deg, turn, _failed([early])))
                results += _relabelled([early], alt.label()) if labelled else [early]
                continue
            steps = trial.sequence(alt_plan)
            collision = scene.check(
                steps,
                trial.T_base_tcp_start,
                part_size,
                plan.T_base_obj,
                alt.T_base_tcp,
                trial.q_actual,
            )
            if all(r.passed for r in collision):
                passing.append((turn, alt, alt_plan, steps, collision))
                continue
            others.append(AlternativeOutcome(alt.yaw_deg, alt.tilt_deg, turn, _failed(collision)))
            results += _relabelled(collision, alt.label()) if labelled else collision
        passing.sort(key=lambda trial_: trial_[0])
        for rank, (turn, alt, alt_plan, steps, collision) in enumerate(passing):
            try:
                checks = collision + trial.preflight(steps)
            except PreflightRefusal as refusal:
                failed = collision + refusal.results
                others.append(AlternativeOutcome(alt.yaw_deg, alt.tilt_deg, turn, _failed(failed)))
                results += _relabelled(failed, alt.label()) if labelled else failed
                continue
            others += [
                AlternativeOutcome(
                    later.yaw_deg,
                    later.tilt_deg,
                    later_turn,
                    [f"clear of the scene, not asked of the controller: turns the wrist "
                     f"{later_turn:.1f} deg, more than the {turn:.1f} deg taken"],
                )
                for later_turn, later, *_ in passing[rank + 1 :]
            ]
            taken = AlternativeOutcome(alt.yaw_deg, alt.tilt_deg, turn, [])
            return Chosen(index, alt_plan, steps, checks, taken, others), results
    return None, results


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
    path_start_s: float = 0.0,
    standoff_m: float = 0.0,
    on_plan: Callable[[PickPlan], None] | None = None,
    start: tuple[Transform, Sequence[float] | None] | None = None,
) -> tuple[Chosen, list[CandidateRefusal]]:
    """The first candidate whose whole sequence (the pick, then the place at
    ``T_base_tcp_place`` when given) passes the chain's plausibility and every pre-flight check,
    and the refusals of those before it. With a scene (``config.scene``), the sequence must
    also keep clear of it (``handeye_pick.scene``: the tool, the part and, unless
    ``scene.arm: unchecked``, the arm's links from the controller's actual joints), and a
    candidate's grasp alternatives are tried before it is refused.

    ``T_base_flange`` (m) is the flange at acquisition; ``T_flange_tcp`` the active TCP offset;
    ``grip`` False leaves the gripper out of the steps (a touch test), ``blend`` False keeps
    every target a stop (``motion.blend_mm`` rounds the corners otherwise, where they save
    more than ``path_start_s``, what a path start costs on the controller, s). The sequence
    starts where the arm stands at ``T_base_flange`` with the controller's actual joints, or at
    ``start``: ``T_base_tcp`` (m) and the joints there (rad; needed when the arm is checked), a
    pose the arm will stand at (a pick checked ahead, ``cell.ahead``). Raises
    ``NoFeasibleCandidate`` when none passes, or the one candidate's own ``PreflightRefusal``
    (every check listed) when there was only one.
    """
    scene = None
    if config.scene is not None:  # python-fcl is imported only by a cell that has a scene
        from handeye_pick.scene.check import SceneCheck

        scene = SceneCheck(config.scene, config.tool_shape, T_flange_tcp, config.robot.model)
    arm_checked = scene is not None and scene.arm is not None
    if start is None:
        T_base_tcp_start = compose(T_base_flange, T_flange_tcp)
        q_start = arm.joint_positions() if arm_checked else None
    else:
        T_base_tcp_start = start[0]
        q_start = tuple(start[1]) if arm_checked and start[1] is not None else None
        if arm_checked and q_start is None:
            raise PlanRefused("a pick checked ahead needs the joints it starts with")
    trial = _Trial(
        config,
        arm,
        verdicts,
        T_base_tcp_start,
        T_base_tcp_place,
        grip,
        blend,
        scene,
        q_start,
        path_start_s,
    )
    refusals: list[CandidateRefusal] = []
    for index, detection in enumerate(detections):
        plan = chain_plan(
            config, calibration, detection, T_base_flange, T_flange_tcp, standoff_m=standoff_m
        )
        if on_plan is not None:
            on_plan(plan)
        plausible = chain_checks(config, calibration, detection.T_cam_obj, T_base_flange)
        if not all(check.passed for check in plausible):  # nothing asked of the controller
            refusals.append(CandidateRefusal.of(index, detection.source, plausible))
            continue
        if trial.scene is None:
            steps = trial.sequence(plan)
            try:
                checks = plausible + trial.preflight(steps)
            except PreflightRefusal as refusal:
                refusals.append(CandidateRefusal.of(index, detection.source, refusal.results))
                continue
            return Chosen(index, plan, steps, checks), refusals
        chosen, results = _try_alternatives(trial, trial.scene, index, detection, plan)
        if chosen is not None:
            return replace(chosen, checks=plausible + chosen.checks), refusals
        refusals.append(CandidateRefusal.of(index, detection.source, results))
    if len(refusals) == 1:  # one detection: its own refusal says it best, every check listed
        raise PreflightRefusal(refusals[0].checks)
    raise NoFeasibleCandidate(refusals)
