"""A pick (or a touch test) of a cell: its capture, the first candidate whose whole sequence
passes every check, that sequence through ``run_operation``, and its result.

Frames and units: detections in the camera frame (``T_cam_obj``); every pose of the result is a
float64 4x4 in metres in the robot base frame (``T_base_tcp``).
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass

from handeye_pick.cell.captures import Capture
from handeye_pick.cell.capturing import live_capture, live_pose_note
from handeye_pick.cell.operation import Planned, run_operation
from handeye_pick.cell.plan import (
    PLACE,
    CandidateRefusal,
    Chosen,
    NoFeasibleCandidate,
    PickPlan,
    StepError,
    choose,
    describe_plan,
    reached_errors,
)
from handeye_pick.cell.records import plan_record
from handeye_pick.cell.sequence import Executed
from handeye_pick.cell.state import CellState
from handeye_pick.detection import Detection
from handeye_pick.errors import InputError, SafetyRefusal, Status
from handeye_pick.geometry import Transform, compose
from handeye_pick.gripper import GraspState
from handeye_pick.safety import CheckResult, PreflightRefusal
from handeye_pick.steps import Move, Step


@dataclass(frozen=True)
class PickResult:
    """A pick that ran to its end (or a dry run)."""

    status: Status  # placed, picked, missed (the gripper closed on nothing), dry-run
    candidate: int  # index of the picked candidate
    plan: PickPlan
    checks: list[CheckResult]
    refused: list[CandidateRefusal]  # earlier candidates that failed a check
    reached: dict[str, Transform]  # move name -> reached T_base_tcp
    errors: dict[str, StepError]  # move name -> reached vs target
    capture: Capture
    cycle: int
    pick_id: str  # the audit records of this pick
    place_index: int | None  # which place pose (None: no place)
    T_base_tcp_place: Transform | None
    cycle_s: float  # wall time of the pick call
    # With a scene: the grasp alternative taken and why the others were not (Chosen's record)
    alternative: dict[str, object] | None = None
    missed: str | None = None  # status missed: why the gripper sensed no part


@dataclass(frozen=True)
class TouchTest:
    """The pick's sequence run as a touch test: to ``standoff_m`` above the point and back,
    switching no gripper and placing nothing; ``before_move`` sees each move's name first."""

    standoff_m: float
    before_move: Callable[[str], None] | None = None


def run_pick(
    state: CellState,
    detections: list[Detection],
    capture: Capture | None,
    *,
    place: bool,
    dry_run: bool,
    request_id: str | None,
    on_plan: Callable[[PickPlan], None] | None,
    touch: TouchTest | None = None,
) -> PickResult:
    """A pick (or a touch test) through ``run_operation``: the capture, the first feasible
    candidate, its sequence, then the place index and the held part brought up to date."""
    started = time.monotonic()
    if not detections:
        raise InputError("pick: no candidate detections given")
    if capture is None:
        state.cycle += 1
    cycle = capture.cycle if capture is not None else state.cycle
    pick = _PickRun(detections, capture, place, dry_run, touch, on_plan)
    pick_id = run_operation(
        state,
        {"cycle": cycle, "request_id": request_id},
        functools.partial(_prepare, state, pick),
        functools.partial(_finish, state, pick),
        outcome_fields={"dry_run": dry_run},
        dry_run=dry_run,
        before_move=touch.before_move if touch is not None else None,
    )
    return pick.result(pick_id, cycle, time.monotonic() - started)


def _prepare(
    state: CellState,
    pick: _PickRun,
    T_flange_tcp: Transform,
    context: dict[str, object],
    outcome: dict[str, object],
) -> Planned:
    """The capture (latched live if none was given, after the readiness check), the first
    candidate whose whole sequence passes every check, and its plan record."""
    config = state.config
    arm = state.link.arm
    capture = pick.capture = pick.capture or live_capture(state)
    outcome["capture_id"] = context["capture_id"] = capture.capture_id
    T_base_flange = capture.T_base_flange
    if T_base_flange is None:  # eye-to-hand: only the position-only yaw needs the arm
        T_base_flange = arm.flange_pose()
    place = config.place if pick.place else None
    plans: list[PickPlan] = []

    def planned(plan: PickPlan) -> None:
        plans.append(plan)
        if pick.on_plan is not None:
            pick.on_plan(plan)

    # A refusal of targets chained from the live pose says so, and how to give the capture pose
    # (a touch test has no capture pose to give: it touches what the camera sees now).
    note = live_pose_note(capture) if pick.touch is None else ""
    path_start_s = state.path_start_s()
    try:
        chosen, pick.refused = choose(
            config,
            state.calibration,
            pick.detections,
            T_base_flange,
            T_flange_tcp,
            arm,
            state.fixed_verdicts,
            T_base_tcp_place=state.next_place_pose(place) if place is not None else None,
            grip=pick.touch is None,
            blend=pick.touch is None,  # a touch test stops at every target
            path_start_s=path_start_s,
            standoff_m=pick.touch.standoff_m if pick.touch is not None else 0.0,
            on_plan=planned,
        )
    except PreflightRefusal as refusal:  # one candidate, refused
        refused = CandidateRefusal.of(0, pick.detections[0].source, refusal.results)
        state.tell_candidates(plans, None, [refused])
        raise PreflightRefusal(refusal.results, note) from None
    except NoFeasibleCandidate as none:
        state.tell_candidates(plans, None, none.refusals)
        raise NoFeasibleCandidate(none.refusals, note) from None
    state.tell_candidates(plans, chosen.index, pick.refused)
    pick.chosen = chosen
    gripper = state.link.gripper
    if gripper is not None and state.holding is None and pick.touch is None:
        # Fingers left closed (a dropped part) would come down on the part: found by the
        # chaos soak, where the next pick after a drop and a resume "missed".
        not_ready = gripper.ready_to_grasp()
        if not_ready is not None:
            raise SafetyRefusal(not_ready)
    if pick.refused:
        outcome["refused"] = [asdict(r) for r in pick.refused]
    pick.place_index = state.place_index if _place_pose(chosen.steps) is not None else None
    state.progress.say("planned: " + describe_plan(chosen.plan))
    state.progress.say(f"pre-flight: {len(chosen.checks)} checks passed")
    detection = pick.detections[chosen.index]
    record = plan_record(config, state.calibration, detection, chosen.plan, capture.source)
    return Planned(
        chosen.steps,
        chosen.checks,
        {
            "dry_run": pick.dry_run,
            "candidate": chosen.index,
            **record,
            "place_index": pick.place_index,
            **chosen.alternative_record(),
        },
        compose(T_base_flange, T_flange_tcp),
        path_start_s if pick.touch is None else None,
    )


def _finish(state: CellState, pick: _PickRun, done: Executed | None) -> dict[str, object]:
    """The pick's outcome fields; the next place pose and the part carried brought up to
    date."""
    chosen = pick.required_chosen()
    pick.reached = done.reached if done is not None else {}
    pick.errors = reached_errors(chosen.steps, pick.reached)
    if done is None:
        pick.status = Status.DRY_RUN
    elif done.grasp is GraspState.MISSED:
        pick.place_index = None
        pick.status = Status.MISSED
        pick.missed = done.missed
    elif pick.place_index is not None:
        state.place_index += 1
        pick.status = Status.PLACED
    else:
        pick.status = Status.PICKED
    if done is not None:  # a part picked and not placed is carried until a place releases it
        state.holding = done.grasp if pick.status is Status.PICKED else None
    return {
        "status": pick.status,
        "candidate": chosen.index,
        "errors": {name: asdict(error) for name, error in pick.errors.items()},
    }


class _PickRun:
    """One pick's inputs, and what it learns as it runs, for its result."""

    def __init__(
        self,
        detections: list[Detection],
        capture: Capture | None,
        place: bool,
        dry_run: bool,
        touch: TouchTest | None,
        on_plan: Callable[[PickPlan], None] | None,
    ) -> None:
        self.detections = detections
        self.capture = capture
        self.place = place
        self.dry_run = dry_run
        self.touch = touch
        self.on_plan = on_plan
        self.chosen: Chosen | None = None
        self.refused: list[CandidateRefusal] = []
        self.place_index: int | None = None
        self.status = Status.DRY_RUN
        self.reached: dict[str, Transform] = {}
        self.errors: dict[str, StepError] = {}
        self.missed: str | None = None  # status missed: why the gripper sensed no part

    def required_chosen(self) -> Chosen:
        if self.chosen is None:  # run_operation calls finish only after prepare chose
            raise RuntimeError("a pick finished before a candidate was chosen")
        return self.chosen

    def result(self, pick_id: str, cycle: int, cycle_s: float) -> PickResult:
        chosen = self.required_chosen()
        if self.capture is None:  # prepare always sets it
            raise RuntimeError("a pick finished without a capture")
        return PickResult(
            status=self.status,
            candidate=chosen.index,
            plan=chosen.plan,
            checks=chosen.checks,
            refused=self.refused,
            reached=self.reached,
            errors=self.errors,
            capture=self.capture,
            cycle=cycle,
            pick_id=pick_id,
            place_index=self.place_index,
            T_base_tcp_place=_place_pose(chosen.steps) if self.place_index is not None else None,
            cycle_s=cycle_s,
            alternative=chosen.alternative_fields(),
            missed=self.missed,
        )


def _place_pose(steps: Sequence[Step]) -> Transform | None:
    """The place target's ``T_base_tcp`` (m) among ``steps``; None when they place nothing."""
    for step in steps:
        if isinstance(step, Move) and step.name == PLACE:
            return step.T_base_tcp
    return None
