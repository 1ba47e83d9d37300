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

import numpy as np

from handeye_pick.cell.ahead import Ahead, AheadRequest, AheadStart, Checked, start_problem
from handeye_pick.cell.captures import Capture
from handeye_pick.cell.capturing import live_capture, live_pose_note
from handeye_pick.cell.operation import Planned, plan_entry, run_operation
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
from handeye_pick.config.schema import PLACE_MOVES, CellConfig
from handeye_pick.detection import Detection
from handeye_pick.errors import InputError, SafetyRefusal, Status
from handeye_pick.geometry import Transform, compose, invert, ur_pose_list
from handeye_pick.gripper import GraspState
from handeye_pick.hand_eye.files import HandEyeCalibration, HandEyeMode
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
    ahead_key: str | None = None,
) -> PickResult:
    """A pick (or a touch test) through ``run_operation``: the capture, the first feasible
    candidate, its sequence, then the place index and the held part brought up to date.
    ``ahead_key``: the key of the request, when it may have been checked ahead (``look``)."""
    started = time.monotonic()
    if not detections:
        raise InputError("pick: no candidate detections given")
    ahead, state.ahead = state.ahead, None
    if ahead is not None and (ahead_key is None or ahead.request.key != ahead_key):
        ahead = None  # another request ran first: its plan record, if any, stays unfinished
    if ahead is not None:
        ahead.wait()
        capture = ahead.capture
    if capture is None:
        state.cycle += 1
    cycle = capture.cycle if capture is not None else state.cycle
    pick = _PickRun(detections, capture, place, dry_run, touch, on_plan, ahead)
    pick_id = run_operation(
        state,
        {"cycle": cycle, "request_id": request_id},
        functools.partial(_prepare, state, pick),
        functools.partial(_finish, state, pick),
        outcome_fields={"dry_run": dry_run},
        dry_run=dry_run,
        before_move=touch.before_move if touch is not None else None,
        audit=ahead.audit if ahead is not None else None,
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
    capture = pick.capture = pick.capture or live_capture(state)
    outcome["capture_id"] = context["capture_id"] = capture.capture_id
    place = config.place if pick.place else None
    T_base_tcp_place = state.next_place_pose(place) if place is not None else None
    replanned = None
    ahead = pick.ahead
    if ahead is not None:
        replanned = ahead.failed or _ahead_problem(state, ahead, T_flange_tcp, T_base_tcp_place)
    checked = ahead.checked if ahead is not None and replanned is None else None
    if ahead is not None and checked is not None:
        chosen, pick.refused, plans = checked
        T_base_flange = _chain_flange(ahead.capture, ahead.start)
        path_start_s = ahead.path_start_s
    else:
        T_base_flange = (  # eye-to-hand: only the position-only yaw needs the arm
            capture.T_base_flange
            if capture.T_base_flange is not None
            else state.link.arm.flange_pose()
        )
        path_start_s = state.path_start_s()
        chosen, pick.refused, plans = _choose(
            state, pick, capture, T_base_flange, T_flange_tcp, T_base_tcp_place, path_start_s
        )
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
    used = ahead if checked is not None else None
    return Planned(
        chosen.steps,
        chosen.checks,
        _record(
            state.config,
            state.calibration,
            pick.detections,
            chosen,
            capture,
            pick.place_index,
            pick.dry_run,
            used.start if used is not None else None,
        ),
        compose(T_base_flange, T_flange_tcp) if used is None else used.start.T_base_tcp,
        path_start_s if pick.touch is None else None,
        written=used is not None and used.audit is not None,
        replanned=replanned if ahead is not None and ahead.audit is not None else None,
    )


def _choose(
    state: CellState,
    pick: _PickRun,
    capture: Capture,
    T_base_flange: Transform,
    T_flange_tcp: Transform,
    T_base_tcp_place: Transform | None,
    path_start_s: float,
) -> Checked:
    """``plan.choose`` from where the arm stands now, refusals told to the observer and
    noting a live flange pose."""
    plans: list[PickPlan] = []

    def planned(plan: PickPlan) -> None:
        plans.append(plan)
        if pick.on_plan is not None:
            pick.on_plan(plan)

    # A refusal of targets chained from the live pose says so, and how to give the capture pose
    # (a touch test has no capture pose to give: it touches what the camera sees now).
    note = live_pose_note(capture) if pick.touch is None else ""
    try:
        chosen, refused = choose(
            state.config,
            state.calibration,
            pick.detections,
            T_base_flange,
            T_flange_tcp,
            state.link.arm,
            state.fixed_verdicts,
            T_base_tcp_place=T_base_tcp_place,
            grip=pick.touch is None,
            blend=pick.touch is None,  # a touch test stops at every target
            path_start_s=path_start_s,
            standoff_m=pick.touch.standoff_m if pick.touch is not None else 0.0,
            on_plan=planned,
        )
    except PreflightRefusal as refusal:  # one candidate, refused
        refused_one = CandidateRefusal.of(0, pick.detections[0].source, refusal.results)
        state.tell_candidates(plans, None, [refused_one])
        raise PreflightRefusal(refusal.results, note) from None
    except NoFeasibleCandidate as none:
        state.tell_candidates(plans, None, none.refusals)
        raise NoFeasibleCandidate(none.refusals, note) from None
    return chosen, refused, plans


def _record(
    config: CellConfig,
    calibration: HandEyeCalibration,
    detections: Sequence[Detection],
    chosen: Chosen,
    capture: Capture,
    place_index: int | None,
    dry_run: bool,
    start: AheadStart | None,
) -> dict[str, object]:
    """A pick plan record's own fields (beyond the context, the targets and the checks);
    ``start``: where a pick checked ahead was checked to start."""
    detection = detections[chosen.index]
    record = plan_record(config, calibration, detection, chosen.plan, capture.source)
    checked_ahead = {}
    if start is not None:
        checked_ahead = {
            "checked_ahead": {
                "start_pose": ur_pose_list(start.T_base_tcp),
                "start_joints": list(start.q_rad) if start.q_rad is not None else None,
            }
        }
    return {
        "dry_run": dry_run,
        "candidate": chosen.index,
        **record,
        "place_index": place_index,
        **chosen.alternative_record(),
        **checked_ahead,
    }


# --- checked ahead (cell/ahead.py) -------------------------------------------------------------


def look(state: CellState, step: str, waiting: Callable[[], AheadRequest | None]) -> None:
    """At a look of a running sequence (the session's thread, the arm moving): once the place
    runs, start checking the pick ``waiting`` names ahead; once that check is done, write its
    plan record. Never raises: a failure leaves the pick to be planned in its turn."""
    try:
        if state.ahead is None and step in PLACE_MOVES:
            request = waiting()
            if request is not None:
                state.ahead = _check_ahead(state, request)
    except Exception as exc:  # never into the running move: it would stop the arm
        state.progress.say(f"the next pick is planned in its turn: {exc}")
    state.record_ahead(wait=False)


def _check_ahead(state: CellState, request: AheadRequest) -> Ahead | None:
    """Start checking ``request`` on its own thread, from where the running sequence ends;
    None when it cannot be (an eye-in-hand pick must name its capture)."""
    config, arm = state.config, state.link.arm
    steps = state.running_steps
    moves = [s for s in steps if isinstance(s, Move)]
    eye_in_hand = state.calibration.mode is HandEyeMode.EYE_IN_HAND
    if not moves or (request.capture is None and eye_in_hand):
        return None
    T_end = moves[-1].T_base_tcp
    T_flange_tcp = arm.tcp_offset()
    q_end = None
    scene, model = config.scene, config.robot.model
    if scene is not None and scene.arm_checked and model is not None:
        from handeye_pick.scene.arm_legs import start_joints  # the branch the arm keeps

        q_end = tuple(
            float(q) for q in start_joints(model, T_flange_tcp, T_end, arm.joint_positions())
        )
    place = config.place if request.place else None
    index = state.place_index + (1 if _place_pose(steps) is not None else 0)
    T_base_tcp_place = place.T_base_tcp[index % len(place.T_base_tcp)] if place else None
    start = AheadStart(T_end, q_end, T_flange_tcp, T_base_tcp_place)
    capture = request.capture
    if capture is None:
        state.cycle += 1
        capture = live_capture(state)  # eye-to-hand: no pose to latch
    path_start_s = state.path_start_s()
    T_base_flange = _chain_flange(capture, start)
    plans: list[PickPlan] = []
    place_index = index if T_base_tcp_place is not None else None
    context: dict[str, object] = {
        "cycle": capture.cycle,
        "request_id": request.request_id,
        "capture_id": capture.capture_id,
    }

    def plan() -> tuple[Checked, dict[str, object]]:
        chosen, refused = choose(
            config,
            state.calibration,
            request.detections,
            T_base_flange,
            T_flange_tcp,
            arm,
            state.fixed_verdicts,
            T_base_tcp_place=T_base_tcp_place,
            grip=True,
            path_start_s=path_start_s,
            on_plan=plans.append,
            start=(T_end, q_end),
        )
        fields = _record(
            config, state.calibration, request.detections, chosen, capture, place_index, False,
            start,
        )
        planned = Planned(chosen.steps, chosen.checks, fields, T_end, path_start_s)
        return (chosen, refused, plans), plan_entry(config, context, planned)

    return Ahead(request, start, capture, capture.cycle, path_start_s, plan)


def _ahead_problem(
    state: CellState, ahead: Ahead, T_flange_tcp: Transform, T_base_tcp_place: Transform | None
) -> str | None:
    """Why a pick checked ahead cannot run as checked, or None: the arm where it was checked to
    start (a fresh sample), the same TCP offset and place pose, no part held."""
    start = ahead.start
    arm = state.link.arm
    elsewhere = start_problem(start, arm.tcp_pose(), arm.joint_positions())
    if elsewhere is not None:
        return elsewhere
    if not np.allclose(T_flange_tcp, start.T_flange_tcp, atol=1e-9):
        return "the active TCP offset changed since the pick was checked"
    same_place = (T_base_tcp_place is None) == (start.T_base_tcp_place is None) and (
        T_base_tcp_place is None
        or start.T_base_tcp_place is None
        or np.allclose(T_base_tcp_place, start.T_base_tcp_place, atol=1e-12)
    )
    if not same_place:
        return "the next place pose is not the one the pick was checked with"
    if state.holding is not None:
        return "a part is held"
    return None


def _chain_flange(capture: Capture, start: AheadStart) -> Transform:
    """The flange pose the chain uses: at the image eye-in-hand, where the arm will stand
    eye-to-hand (only the position-only yaw uses it)."""
    if capture.T_base_flange is not None:
        return capture.T_base_flange
    return start.T_base_tcp @ invert(start.T_flange_tcp)


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
        ahead: Ahead | None = None,
    ) -> None:
        self.ahead = ahead  # the pick as it was checked ahead, if it was
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
