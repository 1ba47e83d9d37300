"""``Cell``: one pick cell session, the public Python API of handeye-pick.

A ``Cell`` loads the config and the hand-eye calibration, connects once (ur_rtde contained in
its child process, the same readiness checks as every command), appends to the audit log, and
runs the cell's operations for as long as the session lasts::

    from handeye_pick import Cell, detection_from_point_mm

    with Cell("cell.yaml") as cell:
        capture = cell.capture()                      # latch T_base_flange where the arm stands
        ...                                           # take the image, detect (camera frame, mm)
        result = cell.pick([detection_from_point_mm([35.0, -20.0, 384.0], "vision")], capture)
        print(result.status, result.candidate)        # "placed" with place configured
        cell.move_to("home")

Frames and units: poses are float64 4x4 transforms in metres in the robot base frame
(``T_base_flange``, ``T_base_tcp``); detections are in the camera frame (``T_cam_obj``).

Safety: every motion (pick, place, named pose) goes through ``safety.preflight`` and is
audited: its plan on disk before the first motion command, its outcome after, whatever the
ending. A robot fault stops the arm (the adapter does that) and halts the cell: every motion
is then refused with ``CellHalted`` until ``resume()``, after the operator cleared the cause on
the pendant. Nothing is ever unlocked, reconnected or re-sent by itself.
"""

from __future__ import annotations

import itertools
import logging
import time
from collections import OrderedDict
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path
from types import TracebackType

from handeye_pick.audit import AuditLog, open_audit
from handeye_pick.calibration.files import (
    CELL_CONFIG,
    HandEyeCalibration,
    HandEyeMode,
    load_hand_eye,
)
from handeye_pick.calibration.plausibility import chain_problems
from handeye_pick.cell.sequence import (
    JointMove,
    Move,
    PickPlan,
    Step,
    StepError,
    append_failure,
    audited_outcome,
    chain_plan,
    check_steps,
    describe_plan,
    execute,
    pick_steps,
    place_steps,
    plan_record,
    reached_errors,
    steps_record,
)
from handeye_pick.config.load import load_config
from handeye_pick.config.schema import CellConfig, NamedPose
from handeye_pick.detection import Detection
from handeye_pick.errors import (
    CellHalted,
    ConfigError,
    InputError,
    PlanRefused,
    RobotConnectionError,
    RobotError,
    RobotFault,
    SafetyRefusal,
    Status,
)
from handeye_pick.geometry import Transform, compose, ur_pose_list
from handeye_pick.gripper import GraspState, Gripper, connect_gripper
from handeye_pick.gripper.config import GripperConfig
from handeye_pick.progress import Progress
from handeye_pick.robot.port import RobotArm, RobotStatus
from handeye_pick.robot.ur.readout import read_controller
from handeye_pick.safety import (  # PreflightRefusal: part of this module's API
    CheckResult,
    ControllerVerdicts,
    PreflightRefusal,
    cell_readiness_problems,
    controller_problems,
    tcp_offset_difference,
    tcp_offset_problems,
    workspace_problem,
)

__all__ = [
    "CandidateRefusal",
    "Capture",
    "Cell",
    "CellStatus",
    "NoFeasibleCandidate",
    "PickPlan",
    "PickResult",
    "PreflightRefusal",
    "StepError",
    "calibration_from_config",
    "connect_ur_rtde",
]

log = logging.getLogger(__name__)

MAX_CAPTURES_KEPT = 64
"""Latched captures a session remembers (oldest forgotten first): a pick names a recent one."""

ArmFactory = Callable[[CellConfig], RobotArm]


class NoFeasibleCandidate(PlanRefused):
    """No candidate passed every pre-flight check; nothing moved. ``refusals`` says why each."""

    def __init__(self, refusals: list[CandidateRefusal]) -> None:
        reasons = "; ".join(
            f"candidate {r.candidate} ({r.source}): {'; '.join(r.reasons)}" for r in refusals
        )
        super().__init__(f"no candidate can be picked, nothing moved: {reasons}")
        self.refusals = refusals


@dataclass(frozen=True)
class CandidateRefusal:
    """Why one candidate detection was not picked."""

    candidate: int  # its index in the request
    source: str  # the detection's source
    reasons: list[str]
    checks: list[CheckResult] = field(default_factory=list)  # every pre-flight check, if run


@dataclass(frozen=True)
class Capture:
    """A latched capture: the flange pose at image acquisition, carried with its detections.

    ``T_base_flange`` (m) is None for eye-to-hand (the camera does not move with the arm).
    ``source`` says where the pose came from: ``latched`` (read steady at capture), ``live``
    (read steady right before a one-shot pick), or a file/flag name.
    """

    capture_id: str
    T_base_flange: Transform | None
    source: str
    timestamp: datetime
    cycle: int


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


@dataclass(frozen=True)
class CellStatus:
    """What the cell looks like right now, and whether it can pick."""

    ready: bool
    problems: list[str]
    halted: str | None  # why the cell is halted, or None
    robot: RobotStatus | None  # None when the link is gone
    T_flange_tcp: Transform | None  # active TCP offset (m)
    tcp_offset_difference: tuple[float, float] | None  # (mm, deg) controller vs config
    T_base_flange: Transform | None
    T_base_tcp: Transform | None
    T_base_cam: Transform | None
    tcp_outside_workspace: str | None
    program_state: str | None = None  # the dashboard's programState (``inspect`` only)
    loaded_program: str | None = None  # the dashboard's loaded program (``inspect`` only)


def calibration_from_config(config: CellConfig) -> HandEyeCalibration:
    """The hand-eye calibration the cell configuration names (file, mode, units, inversion)."""
    hand_eye = config.hand_eye
    return load_hand_eye(
        hand_eye.file, hand_eye.mode, hand_eye.units, hand_eye.invert, settings=CELL_CONFIG
    )


def connect_ur_rtde(config: CellConfig) -> RobotArm:
    """The ur_rtde session for a cell (IO only when a gripper output is configured)."""
    from handeye_pick.robot.ur.arm import URRtdeArm

    return URRtdeArm(
        config.robot.host,
        with_io=isinstance(config.robot.gripper, GripperConfig),
        stop_decel_mps2=config.motion.stop_decel_mps2,
        watchdog_s=config.robot.watchdog_s,
    )


class Cell:
    """One pick cell session; use as a context manager (connects on enter, closes on exit).

    ``config`` is a path to the cell YAML or a loaded ``CellConfig``. ``progress`` receives
    progress lines (silent by default). ``connect`` makes the robot session (ur_rtde by default;
    tests pass their own ``RobotArm``). A cell that is never entered only plans offline
    (``plan`` with a flange pose).
    """

    def __init__(
        self,
        config: CellConfig | str | Path,
        *,
        progress: Progress | None = None,
        connect: ArmFactory = connect_ur_rtde,
    ) -> None:
        self.config = config if isinstance(config, CellConfig) else load_config(Path(config))
        self.calibration = calibration_from_config(self.config)
        self.progress = progress if progress is not None else Progress.quiet()
        self._connect_arm = connect
        self._arm: RobotArm | None = None
        self._gripper: Gripper | None = None
        self._halted: str | None = None
        self._captures: OrderedDict[str, Capture] = OrderedDict()
        self._capture_numbers = itertools.count(1)
        self._cycle = 0
        self._place_index = 0
        self._holding: GraspState | None = None  # a part picked and not yet placed
        self._fixed_verdicts: ControllerVerdicts = {}
        self._audit: AuditLog | None = None

    # --- session ---------------------------------------------------------------------------

    def __enter__(self) -> Cell:
        try:
            self.connect()
        except BaseException:
            self.close()  # the audit file's lock too: __exit__ does not run after this
            raise
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def connect(self, *, request_id: str | None = None) -> None:
        """Open the audit file (``audit.open_audit``: appendable, locked, unfinished picks of a
        killed process closed as abandoned) before anything is sent, then the robot session; a
        failure to connect is audited (step ``connect``) and raised."""
        if self._audit is None:
            self._audit, warnings = open_audit(self.config.audit.file)
            for warning in warnings:
                log.warning("%s", warning)
        outcome: dict[str, object] = {"event": "outcome", "step": "connect", "reached": {}}
        if request_id is not None:
            outcome["request_id"] = request_id
        audit = self._next_audit()
        try:
            with self.progress.step(f"connecting to {self.config.robot.host}"):
                self._arm = self._connect_arm(self.config)
                robot = self.config.robot
                self._gripper = connect_gripper(
                    robot.gripper, robot.host, self._arm, self.progress.say
                )
        except BaseException as exc:
            append_failure(audit, outcome, exc)
            self._close_arm()
            raise
        self._fixed_verdicts.clear()

    def close(self) -> None:
        """Close the robot session and release the audit file; safe to call twice."""
        self._close_arm()
        if self._audit is not None:
            self._audit.close()
            self._audit = None

    def _close_arm(self) -> None:
        """Close the gripper's and the robot's connections (a resume opens fresh ones)."""
        if self._gripper is not None:
            self._gripper.close_connection()
            self._gripper = None
        if self._arm is not None:
            self._arm.close()
            self._arm = None

    def _next_audit(self) -> AuditLog:
        """The audit log of the session's next pick (a new pick id, the session's lock)."""
        if self._audit is None:
            raise RobotConnectionError(
                f"cell {self.config.robot.host}: not connected (use the Cell as a context manager)"
            )
        return self._audit.next_pick()

    @property
    def arm(self) -> RobotArm:
        """The connected robot; RobotConnectionError when the session is closed or lost."""
        if self._arm is None:
            raise RobotConnectionError(
                f"cell {self.config.robot.host}: not connected (use the Cell as a context "
                "manager, or resume after a lost link)"
            )
        return self._arm

    @property
    def halted(self) -> str | None:
        """Why the cell is halted (motion refused until ``resume``), or None."""
        return self._halted

    def resume(self, *, request_id: str | None = None) -> CellStatus:
        """After the operator cleared a fault on the pendant: a fresh robot session, then the
        full readiness check. The cell stays halted (SafetyRefusal) while it is not ready."""
        self._close_arm()
        self.connect(request_id=request_id)
        reason, self._halted = self._halted, None
        status = self.status()
        if not status.ready:
            self._halted = reason
            raise SafetyRefusal(
                f"cell on {self.config.robot.host} is still not ready, staying halted: "
                + "; ".join(status.problems)
            )
        # What the gripper holds after the operator's recovery is unknown: watch no part.
        self._holding = None
        log.warning("cell %s resumed (was halted: %s)", self.config.robot.host, reason)
        return status

    # --- reading -----------------------------------------------------------------------------

    def status(self) -> CellStatus:
        """Controller state, TCP offset against the config, poses, and every readiness problem
        (halted included). Reads only; works while halted. A cell halted by a lost link has no
        robot session left: it reads the controller from outside (``inspect``), so the operator
        still sees what the pendant would show."""
        if self._arm is None:
            if self._halted is None:
                return CellStatus(False, ["not connected"], None, *([None] * 7))
            try:
                return self.inspect()
            except RobotConnectionError as exc:
                problems = [self._halted_problem(), f"the controller does not answer ({exc})"]
                return CellStatus(False, problems, self._halted, *([None] * 7))
        robot = self.config.robot
        state = self._arm.status()
        try:
            T_flange_tcp = self._arm.tcp_offset()
        except RobotFault as exc:  # the control script refuses commands during a stop
            problems = cell_readiness_problems(
                state,
                robot.T_flange_tcp,
                robot.T_flange_tcp,
                tolerance_mm=robot.tcp_offset_tolerance_mm,
                tolerance_deg=robot.tcp_offset_tolerance_deg,
            )
            problems.append(f"the controller does not answer getTCPOffset now ({exc})")
            return self._status(problems, state, None, None)
        problems = cell_readiness_problems(
            state,
            T_flange_tcp,
            robot.T_flange_tcp,
            tolerance_mm=robot.tcp_offset_tolerance_mm,
            tolerance_deg=robot.tcp_offset_tolerance_deg,
        )
        return self._status(problems, state, T_flange_tcp, self._arm.flange_pose())

    def inspect(self) -> CellStatus:
        """The cell's state read from outside, for ``status`` (``robot.readout``): no program is
        started and nothing is written, so the controller is left exactly as it was found, and
        it works beside another session that is driving the arm. Needs no ``connect``.

        Ready means a pick could start now: the controller checks a pick makes, the active TCP
        offset against the config, and no program running on the controller (a pick would stop
        it: a pendant program, or another session mid-pick).
        """
        robot = self.config.robot
        with self.progress.step(f"reading {robot.host}"):
            readout = read_controller(robot.host)
        problems = controller_problems(readout.status)
        if readout.dashboard_problem is not None:
            problems.append(
                f"{readout.dashboard_problem}: handeye-pick needs it to run a pick (ur_rtde 1.6.5 "
                "starts its control program through it); on PolyScope 5 enable it under "
                "Settings > Security > Services"
            )
        if readout.program_running:
            problems.append(
                f"a program is running on the controller ({readout.program_state}): a pick "
                "would stop it; stop it on the pendant, or let the session that runs it finish"
            )
        if readout.T_flange_tcp is None:
            problems.append(
                "this controller does not serve tcp_offset over RTDE (PolyScope 3.12.3 and "
                "5.5.1 on do), so status cannot check the active TCP offset without stopping "
                "the controller's program: update PolyScope, or check with pick --dry-run"
            )
        else:
            problems.extend(
                tcp_offset_problems(
                    readout.T_flange_tcp,
                    robot.T_flange_tcp,
                    tolerance_mm=robot.tcp_offset_tolerance_mm,
                    tolerance_deg=robot.tcp_offset_tolerance_deg,
                )
            )
        state = self._status(problems, readout.status, readout.T_flange_tcp, readout.T_base_flange)
        return replace(
            state, program_state=readout.program_state, loaded_program=readout.loaded_program
        )

    def _halted_problem(self) -> str:
        return f"halted after a fault ({self._halted}): clear it, then resume"

    def _status(
        self,
        problems: list[str],
        state: RobotStatus,
        T_flange_tcp: Transform | None,
        T_base_flange: Transform | None,
    ) -> CellStatus:
        if self._halted is not None:
            problems.insert(0, self._halted_problem())
        if T_flange_tcp is None or T_base_flange is None:
            return CellStatus(not problems, problems, self._halted, state, *([None] * 6))
        T_base_tcp = compose(T_base_flange, T_flange_tcp)
        return CellStatus(
            ready=not problems,
            problems=problems,
            halted=self._halted,
            robot=state,
            T_flange_tcp=T_flange_tcp,
            tcp_offset_difference=tcp_offset_difference(
                T_flange_tcp, self.config.robot.T_flange_tcp
            ),
            T_base_flange=T_base_flange,
            T_base_tcp=T_base_tcp,
            T_base_cam=self.calibration.T_base_cam(T_base_flange),
            tcp_outside_workspace=workspace_problem(T_base_tcp, self.config.workspace),
        )

    def outside_workspace(self, plan: PickPlan) -> dict[str, str]:
        """Pick targets of ``plan`` outside the workspace box, and why (the pure part of the
        pre-flight: the controller's checks need a pick or a dry run)."""
        box = self.config.workspace
        found = {name: workspace_problem(T, box) for name, T in plan.targets().items()}
        return {name: problem for name, problem in found.items() if problem is not None}

    def plan(self, detection: Detection, T_base_flange: Transform | None = None) -> PickPlan:
        """The pick's chain and targets for ``detection``, moving nothing and checking nothing
        on the controller. With ``T_base_flange`` (m, the flange at acquisition) no robot is
        needed and the config's TCP offset is used; without it the robot's flange pose and
        active TCP offset are read now: from the session when connected, otherwise from outside
        like ``inspect`` (no program started, the controller left as found)."""
        if T_base_flange is not None:
            T_flange_tcp = self.config.robot.T_flange_tcp
        elif self._arm is not None:
            T_flange_tcp = self._arm.tcp_offset()
            T_base_flange = self._arm.flange_pose()
        else:
            T_flange_tcp, T_base_flange = self._flange_from_outside()
        return chain_plan(self.config, self.calibration, detection, T_base_flange, T_flange_tcp)

    def _flange_from_outside(self) -> tuple[Transform, Transform]:
        """``(T_flange_tcp, T_base_flange)`` (m) from one RTDE package read from outside."""
        host = self.config.robot.host
        with self.progress.step(f"reading {host}"):
            readout = read_controller(host)
        if readout.T_flange_tcp is None or readout.T_base_flange is None:
            raise RobotFault(
                f"cell {host}: the controller serves no tcp_offset over RTDE (PolyScope older "
                "than 3.12.3 / 5.5.1), so the flange pose cannot be read without starting a "
                "program: give the flange pose (--robot-pose or --robot-pose-ur)"
            )
        return readout.T_flange_tcp, readout.T_base_flange

    # --- capture -----------------------------------------------------------------------------

    def capture(self, pose: str | None = None, *, request_id: str | None = None) -> Capture:
        """Start a cycle: move to the named ``pose`` (default ``capture.pose`` of the config)
        if any, wait until the arm is steady and latch ``T_base_flange`` from a fresh RTDE
        sample. Eye-to-hand latches no pose (the camera is fixed); its capture pose is meant to
        take the arm out of the camera's view, and one must be configured or given."""
        self._require_not_halted()
        name = pose if pose is not None else self.config.capture.pose
        eye_in_hand = self.calibration.mode is HandEyeMode.EYE_IN_HAND
        if name is None and not eye_in_hand:
            raise ConfigError(
                f"{self.config.path}: an eye-to-hand capture moves the arm out of the camera's "
                "view first: set capture.pose to a named pose, or give one"
            )
        self._cycle += 1
        if name is not None:
            self.move_to(name, request_id=request_id)
        T_base_flange = self._steady_flange_pose() if eye_in_hand else None
        capture = self._register(T_base_flange, "latched")
        self._audit_capture(capture, request_id)
        return capture

    def latch_flange_pose(self, *, request_id: str | None = None) -> Transform:
        """``T_base_flange`` (m) where the arm stands, in either mode, moving nothing: waits
        until the arm is steady and reads a fresh RTDE sample; audited as a ``capture``. A
        hand-eye dataset needs the flange pose in both modes (``collect``)."""
        self._require_not_halted()
        self._cycle += 1
        T_base_flange = self._steady_flange_pose()
        self._audit_capture(self._register(T_base_flange, "latched"), request_id)
        return T_base_flange

    def given_capture(self, T_base_flange: Transform, source: str) -> Capture:
        """Register a capture pose measured elsewhere (a detection file's ``capture``, Zivid's
        ``RobotTransform.yaml``, ``--capture-pose-ur``): ``T_base_flange`` (m) at acquisition."""
        if self.calibration.mode is HandEyeMode.EYE_TO_HAND:
            raise InputError(
                f"{source}: an eye-to-hand cell uses no flange pose at capture (the camera is "
                "fixed): drop it, or check hand_eye.mode"
            )
        self._cycle += 1
        return self._register(T_base_flange, source)

    def find_capture(self, capture_id: str) -> Capture:
        """A capture of this session by id; InputError when unknown or forgotten."""
        try:
            return self._captures[capture_id]
        except KeyError:
            raise InputError(
                f"unknown capture_id {capture_id!r}: capture first (this session keeps the "
                f"last {MAX_CAPTURES_KEPT})"
            ) from None

    def _register(self, T_base_flange: Transform | None, source: str) -> Capture:
        capture = Capture(
            capture_id=f"c{next(self._capture_numbers)}",
            T_base_flange=T_base_flange,
            source=source,
            timestamp=datetime.now(timezone.utc),
            cycle=self._cycle,
        )
        self._captures[capture.capture_id] = capture
        while len(self._captures) > MAX_CAPTURES_KEPT:
            self._captures.popitem(last=False)
        return capture

    def _steady_flange_pose(self) -> Transform:
        """Check the TCP offset against the config, then latch the flange pose at rest."""
        self._ready_tcp_offset()
        with self._halt_on_fault():
            return self.arm.steady_flange_pose(self.config.capture.steady_timeout_s)

    def _audit_capture(self, capture: Capture, request_id: str | None) -> None:
        record: dict[str, object] = {
            "event": "capture",
            "cycle": capture.cycle,
            "capture_id": capture.capture_id,
            "flange_pose_source": capture.source,
            "flange_pose": (
                ur_pose_list(capture.T_base_flange) if capture.T_base_flange is not None else None
            ),
        }
        if request_id is not None:
            record["request_id"] = request_id
        self._next_audit().append(record)

    # --- pick --------------------------------------------------------------------------------

    def pick(
        self,
        candidates: Detection | Sequence[Detection],
        capture: Capture | None = None,
        *,
        place: bool = True,
        dry_run: bool = False,
        request_id: str | None = None,
        on_plan: Callable[[PickPlan], None] | None = None,
    ) -> PickResult:
        """Pick the first candidate that passes every check, then place it (when ``place`` and
        a place is configured).

        ``capture`` carries the flange pose at image acquisition (eye-in-hand). Without one, an
        eye-in-hand pick reads the flange pose now, only while the arm is steady (audited as
        ``flange_pose_source: live``): right only if the arm has not moved since the image.
        Raises ``NoFeasibleCandidate`` (nothing moved), ``SafetyRefusal`` (cell not ready,
        nothing moved), ``CellHalted``, ``RobotError`` (the arm was stopped; the cell halts) or
        ``KeyboardInterrupt`` (after stopL). Every ending is in the audit file. ``on_plan`` sees
        each candidate's plan as soon as it exists, before its checks (for reports).
        """
        detections = [candidates] if isinstance(candidates, Detection) else list(candidates)
        return self._pick(
            detections,
            capture,
            place=place,
            dry_run=dry_run,
            request_id=request_id,
            on_plan=on_plan,
        )

    def touch_test(
        self,
        detection: Detection,
        standoff_m: float,
        *,
        before_move: Callable[[str], None] | None = None,
        on_plan: Callable[[PickPlan], None] | None = None,
    ) -> PickResult:
        """The pick's sequence to ``standoff_m`` above a camera point and back, switching no
        gripper and placing nothing; ``before_move`` sees each move's name first."""
        return self._pick(
            [detection],
            None,
            place=False,
            dry_run=False,
            request_id=None,
            standoff_m=standoff_m,
            grip=False,
            before_move=before_move,
            on_plan=on_plan,
        )

    def _pick(
        self,
        detections: list[Detection],
        capture: Capture | None,
        *,
        place: bool,
        dry_run: bool,
        request_id: str | None,
        standoff_m: float = 0.0,
        grip: bool = True,
        before_move: Callable[[str], None] | None = None,
        on_plan: Callable[[PickPlan], None] | None = None,
    ) -> PickResult:
        started = time.monotonic()
        if not detections:
            raise InputError("pick: no candidate detections given")
        if capture is None:
            self._cycle += 1
        cycle = capture.cycle if capture is not None else self._cycle
        audit = self._next_audit()
        context: dict[str, object] = {"cycle": cycle, "request_id": request_id}
        outcome: dict[str, object] = {"event": "outcome", **context, "dry_run": dry_run}
        with self._halt_on_fault(), audited_outcome(audit, outcome):
            self._require_not_halted()
            T_flange_tcp = self._ready_tcp_offset()
            if capture is None:
                capture = self._live_capture()  # the TCP offset was checked just above
            outcome["capture_id"] = context["capture_id"] = capture.capture_id
            T_base_flange = capture.T_base_flange
            if T_base_flange is None:  # eye-to-hand: only the position-only yaw needs the arm
                T_base_flange = self.arm.flange_pose()
            chosen, refusals = self._choose(
                detections, T_base_flange, T_flange_tcp, standoff_m, grip, place, on_plan
            )
            index, plan, steps, checks = chosen
            if refusals:
                outcome["refused"] = [asdict(r) for r in refusals]
            place_index = self._place_index if _has_place(steps) else None
            self.progress.say("planned: " + describe_plan(plan))
            self.progress.say(f"pre-flight: {len(checks)} checks passed")
            audit.append(
                {
                    "event": "plan",
                    **context,
                    "dry_run": dry_run,
                    "candidate": index,
                    **plan_record(
                        self.config, self.calibration, detections[index], plan, capture.source
                    ),
                    "targets": steps_record(steps),
                    "place_index": place_index,
                    "checks": [asdict(check) for check in checks],
                }
            )
            reached: dict[str, Transform] = {}
            status = Status.DRY_RUN
            if not dry_run:
                done = execute(
                    self.config, steps, self.arm, self.progress, outcome, before_move, self._gripper
                )
                reached = done.reached
                if done.grasp is GraspState.MISSED:
                    status, place_index = Status.MISSED, None
                elif place_index is not None:
                    self._place_index += 1
                    status = Status.PLACED
                else:
                    status = Status.PICKED
                # A part picked and not placed is carried until a place releases it.
                self._holding = done.grasp if status is Status.PICKED else None
            errors = reached_errors(steps, reached)
            outcome.update(
                status=status,
                candidate=index,
                errors={name: asdict(error) for name, error in errors.items()},
            )
        place_pose = _place_pose(steps) if place_index is not None else None
        return PickResult(
            status=status,
            candidate=index,
            plan=plan,
            checks=checks,
            refused=refusals,
            reached=reached,
            errors=errors,
            capture=capture,
            cycle=cycle,
            pick_id=audit.pick_id,
            place_index=place_index,
            T_base_tcp_place=place_pose,
            cycle_s=time.monotonic() - started,
        )

    def _choose(
        self,
        detections: list[Detection],
        T_base_flange: Transform,
        T_flange_tcp: Transform,
        standoff_m: float,
        grip: bool,
        place: bool,
        on_plan: Callable[[PickPlan], None] | None,
    ) -> tuple[tuple[int, PickPlan, list[Step], list[CheckResult]], list[CandidateRefusal]]:
        """The first candidate whose whole sequence passes the pre-flight, and the refusals of
        those before it; NoFeasibleCandidate when none passes."""
        refusals: list[CandidateRefusal] = []
        place_config = self.config.place if place else None
        for index, detection in enumerate(detections):
            plan = chain_plan(
                self.config,
                self.calibration,
                detection,
                T_base_flange,
                T_flange_tcp,
                standoff_m=standoff_m,
            )
            if on_plan is not None:
                on_plan(plan)
            steps = pick_steps(plan, grip=grip)
            if place_config is not None:
                T_place = place_config.T_base_tcp[self._place_index % len(place_config.T_base_tcp)]
                steps += place_steps(T_place, place_config, grip=grip)
            chain_checks = self._plausibility_checks(detection, T_base_flange)
            try:
                if not all(check.passed for check in chain_checks):
                    raise PreflightRefusal(chain_checks)  # nothing asked of the controller
                checks = chain_checks + check_steps(
                    self.config, steps, self.arm, self._fixed_verdicts
                )
            except PreflightRefusal as refusal:
                failed = [
                    f"{r.target} {r.name}: {r.detail}" for r in refusal.results if not r.passed
                ]
                refusals.append(CandidateRefusal(index, detection.source, failed, refusal.results))
                continue
            return (index, plan, steps, checks), refusals
        if len(refusals) == 1:  # one detection: its own refusal says it best, every check listed
            raise PreflightRefusal(refusals[0].checks)
        raise NoFeasibleCandidate(refusals)

    def _plausibility_checks(
        self, detection: Detection, T_base_flange: Transform
    ) -> list[CheckResult]:
        """The chain's plausibility (``plausibility.chain_problems``: an inverted or swapped
        calibration, an object out of the camera's range) as pre-flight results, target
        ``chain``; a check the config acknowledges passes and says so."""
        eye_in_hand = self.calibration.mode is HandEyeMode.EYE_IN_HAND
        problems = chain_problems(
            self.calibration,
            T_base_flange if eye_in_hand else None,
            detection.T_cam_obj,
            self.config.workspace,
            self.config.hand_eye.acknowledge,
            measured=self.config.hand_eye.camera_position,
        )
        acknowledge = self.calibration.settings.acknowledge
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

    def _live_capture(self) -> Capture:
        if self.calibration.mode is HandEyeMode.EYE_TO_HAND:
            return self._register(None, "none (eye-to-hand)")
        return self._register(
            self.arm.steady_flange_pose(self.config.capture.steady_timeout_s), "live"
        )

    # --- place and named poses -------------------------------------------------------------

    def place(self, *, request_id: str | None = None) -> Transform:
        """Put a held part down at the next place pose (approach, place, release, retreat);
        returns that place pose ``T_base_tcp``. ConfigError when no place is configured."""
        place = self.config.place
        if place is None:
            raise ConfigError(f"{self.config.path}: no place section: nowhere to put a part")
        T_place = place.T_base_tcp[self._place_index % len(place.T_base_tcp)]
        record = {"place_index": self._place_index}
        self._run_fixed(place_steps(T_place, place, grip=True), "place", request_id, record)
        self._holding = None
        self._place_index += 1
        return T_place

    def move_to(self, pose: str | NamedPose, *, request_id: str | None = None) -> Transform:
        """Move to a named pose of the config, or to a ``NamedPose`` given directly (moveJ for
        joints, moveL for a TCP pose), checked and audited like any motion; returns the reached
        ``T_base_tcp``."""
        self._require_not_halted()
        target = self.config.pose(pose) if isinstance(pose, str) else pose
        steps = [_named_move(target)]
        reached = self._run_fixed(steps, f"move {target.name}", request_id, {"pose": target.name})
        return reached[target.name]

    def _run_fixed(
        self,
        steps: list[Step],
        what: str,
        request_id: str | None,
        record: Mapping[str, object],
    ) -> dict[str, Transform]:
        """Readiness, pre-flight, plan record, moves, outcome record for configured targets."""
        audit = self._next_audit()
        context: dict[str, object] = {"cycle": self._cycle, "request_id": request_id, **record}
        outcome: dict[str, object] = {"event": "outcome", **context, "operation": what}
        with self._halt_on_fault(), audited_outcome(audit, outcome):
            self._require_not_halted()
            self._ready_tcp_offset()
            checks = check_steps(self.config, steps, self.arm, self._fixed_verdicts)
            audit.append(
                {
                    "event": "plan",
                    **context,
                    "operation": what,
                    "config": str(self.config.path),
                    "host": self.config.robot.host,
                    "targets": steps_record(steps),
                    "checks": [asdict(check) for check in checks],
                }
            )
            reached = execute(
                self.config,
                steps,
                self.arm,
                self.progress,
                outcome,
                gripper=self._gripper,
                holding=self._holding,  # a carried part is watched on every move
            ).reached
            outcome["status"] = Status.DONE
        return reached

    # --- checks ------------------------------------------------------------------------------

    def check_pose(self, T_base_tcp: Transform) -> list[str]:
        """Every pre-flight problem a moveL to ``T_base_tcp`` (m) would meet, moving nothing:
        workspace box, tilt, motion caps, the controller's safety limits and IK. Empty when
        the move would pass (``poses`` keeps only such targets)."""
        try:
            check_steps(self.config, [Move("target", T_base_tcp)], self.arm, self._fixed_verdicts)
        except PreflightRefusal as refusal:
            return [f"{r.name}: {r.detail}" for r in refusal.results if not r.passed]
        return []

    def _require_not_halted(self) -> None:
        if self._halted is not None:
            raise CellHalted(
                f"cell {self.config.robot.host} is halted after a fault ({self._halted}): "
                "clear the cause on the pendant, then resume; nothing moved"
            )

    def _ready_tcp_offset(self) -> Transform:
        """Refuse an unready cell (every problem listed); the active TCP offset when ready."""
        robot = self.config.robot
        T_flange_tcp = self.arm.tcp_offset()
        problems = cell_readiness_problems(
            self.arm.status(),
            T_flange_tcp,
            robot.T_flange_tcp,
            tolerance_mm=robot.tcp_offset_tolerance_mm,
            tolerance_deg=robot.tcp_offset_tolerance_deg,
        )
        if problems:
            raise SafetyRefusal(f"cell on {robot.host} is not ready: " + "; ".join(problems))
        return T_flange_tcp

    @contextmanager
    def _halt_on_fault(self) -> Iterator[None]:
        """A robot error halts the cell (the adapter has stopped the arm); a lost link also ends
        the robot session, so ``resume`` starts a fresh one."""
        try:
            yield
        except RobotError as exc:
            self._halted = f"{type(exc).__name__}: {exc}"
            if isinstance(exc, RobotConnectionError):
                self._close_arm()
            raise


def _named_move(pose: NamedPose) -> Step:
    if pose.q_rad is not None:
        return JointMove(pose.name, pose.q_rad)
    if pose.T_base_tcp is None:  # the config loader allows exactly one of the two
        raise ConfigError(f"pose {pose.name!r} has neither joints nor a TCP pose")
    return Move(pose.name, pose.T_base_tcp, fixed=True)


def _has_place(steps: Sequence[Step]) -> bool:
    return any(isinstance(step, Move) and step.name == "place" for step in steps)


def _place_pose(steps: Sequence[Step]) -> Transform | None:
    for step in steps:
        if isinstance(step, Move) and step.name == "place":
            return step.T_base_tcp
    return None
