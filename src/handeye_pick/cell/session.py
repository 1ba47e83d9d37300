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

Safety: every motion (pick, place, named pose, touch test) runs through one skeleton,
``Cell._run``: halt guard, readiness, pre-flight (``safety``), its plan on disk before the first
motion command, the moves, its outcome after, whatever the ending. A robot fault stops the arm
(the adapter does that) and halts the cell: every motion is then refused with ``CellHalted``
until ``resume()``, after the operator cleared the cause on the pendant. Nothing is ever
unlocked, reconnected or re-sent by itself.
"""

from __future__ import annotations

import functools
import logging
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from types import TracebackType

from handeye_pick.audit import AuditLog, open_audit
from handeye_pick.calibration.files import (
    CELL_CONFIG,
    HandEyeCalibration,
    HandEyeMode,
    load_hand_eye,
)
from handeye_pick.cell.captures import Capture, CaptureBook
from handeye_pick.cell.lock import CellLock
from handeye_pick.cell.observer import CellObserver, Contained
from handeye_pick.cell.plan import (
    PLACE,
    CandidateRefusal,
    Chosen,
    NoFeasibleCandidate,
    PickPlan,
    StepError,
    blended,
    chain_plan,
    check_steps,
    choose,
    describe_plan,
    place_steps,
    reached_errors,
    with_scene_checks,
)
from handeye_pick.cell.records import (
    append_failure,
    audited_outcome,
    blends_record,
    plan_record,
    steps_record,
)
from handeye_pick.cell.sequence import Executed, SequenceWatch, execute
from handeye_pick.cell.status import (
    CellStatus,
    flange_from_outside,
    halted_without_link,
    outside_status,
    session_status,
    unread,
)
from handeye_pick.cell.steps import JointMove, Move, Step
from handeye_pick.config.load import load_config
from handeye_pick.config.schema import CellConfig, NamedPose, PlaceConfig, via_move
from handeye_pick.detection import Detection
from handeye_pick.errors import (
    ConfigError,
    InputError,
    RobotConnectionError,
    RobotError,
    SafetyRefusal,
    Status,
    StopRequested,
)
from handeye_pick.geometry import Transform, compose
from handeye_pick.gripper import GraspState, Gripper, connect_gripper
from handeye_pick.gripper.config import GripperConfig
from handeye_pick.progress import Progress
from handeye_pick.robot.port import RobotArm, SampleListener
from handeye_pick.safety import (
    CheckResult,
    ControllerVerdicts,
    PreflightRefusal,
    ensure_not_halted,
    ensure_ready,
    workspace_problem,
)

log = logging.getLogger(__name__)

ArmFactory = Callable[[CellConfig], RobotArm]


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


@dataclass(frozen=True)
class TouchTest:
    """The pick's sequence run as a touch test: to ``standoff_m`` above the point and back,
    switching no gripper and placing nothing; ``before_move`` sees each move's name first."""

    standoff_m: float
    before_move: Callable[[str], None] | None = None


@dataclass(frozen=True)
class Planned:
    """A sequence ready to run: its steps, the checks they all passed, and the fields of its
    plan record beyond the context, the targets and the checks."""

    steps: list[Step]
    checks: list[CheckResult]
    record: dict[str, object]
    T_base_tcp_start: Transform | None = None  # where the TCP stands as it starts (m), if known


Prepare = Callable[[Transform, dict[str, object], dict[str, object]], Planned]
"""Plans and checks a sequence, given the active TCP offset ``T_flange_tcp`` (m), the context
of its records and its outcome record (both may gain fields: the capture, refused candidates)."""

Finish = Callable[[Executed | None], dict[str, object]]
"""The outcome's ``status`` and own fields once the steps ran (None: a dry run)."""


def calibration_from_config(config: CellConfig) -> HandEyeCalibration:
    """The hand-eye calibration the cell configuration names (file, mode, units, inversion)."""
    hand_eye = config.hand_eye
    return load_hand_eye(
        hand_eye.file, hand_eye.mode, hand_eye.units, hand_eye.invert, settings=CELL_CONFIG
    )


def connect_ur_rtde(config: CellConfig, on_sample: SampleListener | None = None) -> RobotArm:
    """The ur_rtde session for a cell (IO only when a gripper output is configured);
    ``on_sample`` hears every RTDE sample it reads."""
    from handeye_pick.robot.ur.arm import URRtdeArm

    return URRtdeArm(
        config.robot.host,
        with_io=isinstance(config.robot.gripper, GripperConfig),
        stop_decel_mps2=config.motion.stop_decel_mps2,
        watchdog_s=config.robot.watchdog_s,
        on_sample=on_sample,
    )


class Cell:
    """One pick cell session; use as a context manager (connects on enter, closes on exit).

    ``config`` is a path to the cell YAML or a loaded ``CellConfig``. ``progress`` receives
    progress lines (silent by default). ``connect`` makes the robot session (ur_rtde by default;
    tests pass their own ``RobotArm``). A cell that is never entered only plans offline
    (``plan`` with a flange pose). ``observer`` (``cell.observer.CellObserver``, a recording or
    a live view) hears what the session does; its failures are contained (``Contained``): it
    can never break a cycle. With the default ``connect`` it also hears every RTDE sample.
    """

    def __init__(
        self,
        config: CellConfig | str | Path,
        *,
        progress: Progress | None = None,
        connect: ArmFactory = connect_ur_rtde,
        observer: CellObserver | None = None,
    ) -> None:
        self.config = config if isinstance(config, CellConfig) else load_config(Path(config))
        self._observer = Contained(observer, "recording") if observer is not None else None
        if self._observer is not None and connect is connect_ur_rtde:
            connect = functools.partial(connect_ur_rtde, on_sample=self._observer.on_sample)
        # see watch_steps and request_stop
        self._watch = SequenceWatch(
            on_reached=self._observer.on_reached if self._observer is not None else None
        )
        self.calibration = calibration_from_config(self.config)
        self.progress = progress if progress is not None else Progress.quiet()
        self._connect_arm = connect
        self._arm: RobotArm | None = None
        self._gripper: Gripper | None = None
        self._halted: str | None = None
        self._captures = CaptureBook()
        self._cycle = 0
        self._place_index = 0
        self._holding: GraspState | None = None  # a part picked and not yet placed
        self._fixed_verdicts: ControllerVerdicts = {}
        self._audit: AuditLog | None = None
        self._lock = CellLock(self.config.robot.host)
        self.last_pick_id: str | None = None
        """The ``pick_id`` of the audit records of the latest operation, whatever its ending
        (a report of a failed pick carries it)."""

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
        """Take the robot's lock (one session per robot: ``CellInUse`` names the holder, and
        nothing is opened or sent), open the audit file (``audit.open_audit``: appendable,
        locked, unfinished picks of a killed process closed as abandoned) before anything is
        sent, then the robot session; a failure to connect is audited (step ``connect``) and
        raised."""
        self._lock.acquire()
        if self._audit is None:
            self._audit, warnings = open_audit(self.config.audit.file)
            for warning in warnings:
                log.warning("%s", warning)
            if self._observer is not None:
                self._audit.on_append = self._observer.on_audit
        outcome: dict[str, object] = {"event": "outcome", "step": "connect", "reached": {}}
        if request_id is not None:
            outcome["request_id"] = request_id
        audit = self._next_audit()
        self.last_pick_id = audit.pick_id
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
        self._tell_status()

    def close(self) -> None:
        """Close the robot session and release the audit file; safe to call twice."""
        self._close_arm()
        self._lock.release()
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

    def watch_steps(self, on_step: Callable[[str], None]) -> None:
        """``on_step`` hears the name of each step of a running sequence as it starts (a blended
        path's waypoints included), on the thread that runs it."""
        self._watch = replace(self._watch, on_step=on_step)

    def request_stop(self, why: str = "stop requested") -> None:
        """Halt the cell now and brake a sequence in flight at its next look (every few
        milliseconds while the arm moves; before the next step otherwise): stopL, outcome
        ``stopped``. Safe to call from any thread; ``resume`` ends the halt."""
        if self._halted is None:
            self._halted = why
        self._watch.stop.set()
        self._tell_status()

    def resume(self, *, request_id: str | None = None) -> CellStatus:
        """After the operator cleared a fault on the pendant: a fresh robot session, then the
        full readiness check. The cell stays halted (SafetyRefusal) while it is not ready.
        Each attempt that got as far as the readiness check is audited as a ``resume`` record
        (``status`` ready or not-ready, ``halted``: why the cell was halted), so the audit file
        alone says how long the cell stood."""
        self._close_arm()
        self.connect(request_id=request_id)
        reason, self._halted = self._halted, None
        status = self.status()
        record: dict[str, object] = {
            "event": "resume",
            "request_id": request_id,
            "status": Status.READY if status.ready else Status.NOT_READY,
            "halted": reason,
            "problems": status.problems,
        }
        self._next_audit().append(record)
        if not status.ready:
            self._halted = reason
            raise SafetyRefusal(
                f"cell on {self.config.robot.host} is still not ready, staying halted: "
                + "; ".join(status.problems)
            )
        # What the gripper holds after the operator's recovery is unknown: watch no part.
        self._holding = None
        self._watch.stop.clear()
        self._tell_status()
        log.warning("cell %s resumed (was halted: %s)", self.config.robot.host, reason)
        return status

    def note_cloud(self, path: Path, capture: Capture | None) -> None:
        """The vision program's point cloud of ``capture`` (a file, camera frame, mm), for the
        observer (a recording shows it); the cell itself never reads it."""
        if self._observer is not None:
            self._observer.on_cloud(path, capture)

    def _tell_status(self, running: dict[str, object] | None = None) -> None:
        """The observer hears the session's state: running (``running`` says what), halted
        (and why) or idle."""
        if self._observer is None:
            return
        if running is not None:
            status: dict[str, object] = {"state": "running", **running}
        elif self._halted is not None:
            status = {"state": "halted", "halted_reason": self._halted}
        else:
            status = {"state": "idle"}
        self._observer.on_status({"host": self.config.robot.host, **status})

    # --- reading -----------------------------------------------------------------------------

    def status(self) -> CellStatus:
        """Controller state, TCP offset against the config, poses, and every readiness problem
        (halted included). Reads only; works while halted. A cell halted by a lost link has no
        robot session left: it reads the controller from outside (``inspect``), so the operator
        still sees what the pendant would show."""
        if self._arm is not None:
            return session_status(self._arm, self.config, self.calibration, self._halted)
        if self._halted is None:
            return unread(["not connected"], None)
        return halted_without_link(self.config, self.calibration, self._halted, self.progress)

    def inspect(self) -> CellStatus:
        """The cell's state read from outside, for ``status`` (``cell.status.outside_status``):
        no program is started and nothing is written, so the controller is left exactly as it
        was found. Needs no ``connect``."""
        return outside_status(self.config, self.calibration, self._halted, self.progress)

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
            T_flange_tcp, T_base_flange = flange_from_outside(self.config, self.progress)
        return chain_plan(self.config, self.calibration, detection, T_base_flange, T_flange_tcp)

    def check_pose(self, T_base_tcp: Transform) -> list[str]:
        """Every pre-flight problem a moveL to ``T_base_tcp`` (m) would meet, moving nothing:
        workspace box, tilt, motion caps, the controller's safety limits and IK. Empty when
        the move would pass (``poses`` keeps only such targets)."""
        try:
            check_steps(self.config, [Move("target", T_base_tcp)], self.arm, self._fixed_verdicts)
        except PreflightRefusal as refusal:
            return [f"{r.name}: {r.detail}" for r in refusal.results if not r.passed]
        return []

    # --- capture -----------------------------------------------------------------------------

    def capture(self, pose: str | None = None, *, request_id: str | None = None) -> Capture:
        """Start a cycle: move to the named ``pose`` (default ``capture.pose`` of the config)
        if any, wait until the arm is steady and latch ``T_base_flange`` from a fresh RTDE
        sample. Eye-to-hand latches no pose (the camera is fixed); its capture pose is meant to
        take the arm out of the camera's view, and one must be configured or given."""
        ensure_not_halted(self.config.robot.host, self._halted)
        name = pose if pose is not None else self.config.capture.pose
        eye_in_hand = self.calibration.mode is HandEyeMode.EYE_IN_HAND
        if name is None and not eye_in_hand:
            raise ConfigError(
                f"{self.config.path}: an eye-to-hand capture moves the arm out of the camera's "
                "view first: set capture.pose to a named pose, or give one"
            )
        self._cycle += 1
        if name is not None:
            self._move_to_capture(name, request_id)
        T_base_flange = self._steady_flange_pose() if eye_in_hand else None
        capture = self._register_capture(T_base_flange, "latched")
        self._next_audit().append(capture.record(request_id))
        return capture

    def _move_to_capture(self, name: str, request_id: str | None) -> None:
        """To the capture pose ``name``; to ``capture.pose`` through ``capture.via``, blended
        as ``motion.blend_mm`` allows."""
        capture = self.config.capture
        via = capture.via if name == capture.pose else ()
        steps: list[Step] = [
            Move(via_move(pose.name), pose.T_base_tcp, fixed=True)
            for pose in via
            if pose.T_base_tcp is not None  # the config loader takes only TCP poses as via
        ]
        steps.append(_named_move(self.config.pose(name)))
        self._run_fixed(steps, f"move {name}", request_id, {"pose": name})

    def latch_flange_pose(self, *, request_id: str | None = None) -> Transform:
        """``T_base_flange`` (m) where the arm stands, in either mode, moving nothing: waits
        until the arm is steady and reads a fresh RTDE sample; audited as a ``capture``. A
        hand-eye dataset needs the flange pose in both modes (``collect``)."""
        ensure_not_halted(self.config.robot.host, self._halted)
        self._cycle += 1
        T_base_flange = self._steady_flange_pose()
        capture = self._register_capture(T_base_flange, "latched")
        self._next_audit().append(capture.record(request_id))
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
        return self._register_capture(T_base_flange, source)

    def find_capture(self, capture_id: str) -> Capture:
        """A capture of this session by id; InputError when unknown or forgotten."""
        return self._captures.find(capture_id)

    def request_capture(self, capture_id: str | None) -> Capture | None:
        """The capture a pick *request* of a running session uses (``run``): the one it names.
        Eye-to-hand needs none (None). Eye-in-hand must name one (InputError): in a session the
        arm moves between image and pick, so the flange read at pick time (what ``pick`` does
        with no capture, for the one-shot command) would not be the flange of the image."""
        if capture_id is not None:
            return self.find_capture(capture_id)
        if self.calibration.mode is HandEyeMode.EYE_IN_HAND:
            raise InputError(
                "pick: an eye-in-hand pick needs the capture_id of the capture its image "
                "was taken at (send a capture request first)"
            )
        return None

    def _live_capture(self) -> Capture:
        if self.calibration.mode is HandEyeMode.EYE_TO_HAND:
            return self._register_capture(None, "none (eye-to-hand)")
        T_base_flange = self.arm.steady_flange_pose(self.config.capture.steady_timeout_s)
        return self._register_capture(T_base_flange, "live")

    def _register_capture(self, T_base_flange: Transform | None, source: str) -> Capture:
        """A new capture of this cycle (the observer hears of it)."""
        capture = self._captures.register(T_base_flange, source, self._cycle)
        if self._observer is not None:
            self._observer.on_capture(capture)
        return capture

    def _steady_flange_pose(self) -> Transform:
        """Check the TCP offset against the config, then latch the flange pose at rest."""
        self._ready_tcp_offset()
        with self._halt_on_fault():
            return self.arm.steady_flange_pose(self.config.capture.steady_timeout_s)

    # --- motion ------------------------------------------------------------------------------

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
            on_plan=on_plan,
            touch=TouchTest(standoff_m, before_move),
        )

    def place(self, *, request_id: str | None = None) -> Transform:
        """Put a held part down at the next place pose (approach, place, release, retreat);
        returns that place pose ``T_base_tcp``. ConfigError when no place is configured."""
        place = self.config.place
        if place is None:
            raise ConfigError(f"{self.config.path}: no place section: nowhere to put a part")
        T_place = self._next_place_pose(place)
        steps = place_steps(T_place, place, grip=True)
        self._run_fixed(steps, "place", request_id, {"place_index": self._place_index})
        self._holding = None
        self._place_index += 1
        return T_place

    def move_to(self, pose: str | NamedPose, *, request_id: str | None = None) -> Transform:
        """Move to a named pose of the config, or to a ``NamedPose`` given directly (moveJ for
        joints, moveL for a TCP pose), checked and audited like any motion; returns the reached
        ``T_base_tcp``."""
        ensure_not_halted(self.config.robot.host, self._halted)
        target = self.config.pose(pose) if isinstance(pose, str) else pose
        steps = [_named_move(target)]
        reached = self._run_fixed(steps, f"move {target.name}", request_id, {"pose": target.name})
        return reached[target.name]

    def _pick(
        self,
        detections: list[Detection],
        capture: Capture | None,
        *,
        place: bool,
        dry_run: bool,
        request_id: str | None,
        on_plan: Callable[[PickPlan], None] | None,
        touch: TouchTest | None = None,
    ) -> PickResult:
        """A pick (or a touch test) through ``_run``: the capture, the first feasible candidate,
        its sequence, then the place index and the held part brought up to date."""
        started = time.monotonic()
        if not detections:
            raise InputError("pick: no candidate detections given")
        if capture is None:
            self._cycle += 1
        cycle = capture.cycle if capture is not None else self._cycle
        pick = _PickRun(detections, capture, place, dry_run, touch, on_plan)
        pick_id = self._run(
            {"cycle": cycle, "request_id": request_id},
            functools.partial(self._prepare_pick, pick),
            functools.partial(self._finish_pick, pick),
            outcome_fields={"dry_run": dry_run},
            dry_run=dry_run,
            before_move=touch.before_move if touch is not None else None,
        )
        return pick.result(pick_id, cycle, time.monotonic() - started)

    def _prepare_pick(
        self,
        pick: _PickRun,
        T_flange_tcp: Transform,
        context: dict[str, object],
        outcome: dict[str, object],
    ) -> Planned:
        """The capture (latched live if none was given, after the readiness check), the first
        candidate whose whole sequence passes every check, and its plan record."""
        capture = pick.capture = pick.capture or self._live_capture()
        outcome["capture_id"] = context["capture_id"] = capture.capture_id
        T_base_flange = capture.T_base_flange
        if T_base_flange is None:  # eye-to-hand: only the position-only yaw needs the arm
            T_base_flange = self.arm.flange_pose()
        place = self.config.place if pick.place else None
        plans: list[PickPlan] = []

        def planned(plan: PickPlan) -> None:
            plans.append(plan)
            if pick.on_plan is not None:
                pick.on_plan(plan)

        try:
            chosen, pick.refused = choose(
                self.config,
                self.calibration,
                pick.detections,
                T_base_flange,
                T_flange_tcp,
                self.arm,
                self._fixed_verdicts,
                T_base_tcp_place=self._next_place_pose(place) if place is not None else None,
                grip=pick.touch is None,
                blend=pick.touch is None,  # a touch test stops at every target
                standoff_m=pick.touch.standoff_m if pick.touch is not None else 0.0,
                on_plan=planned,
            )
        except PreflightRefusal as refusal:  # one candidate, refused
            refused = CandidateRefusal.of(0, pick.detections[0].source, refusal.results)
            self._tell_candidates(plans, None, [refused])
            raise
        except NoFeasibleCandidate as none:
            self._tell_candidates(plans, None, none.refusals)
            raise
        self._tell_candidates(plans, chosen.index, pick.refused)
        pick.chosen = chosen
        if self._gripper is not None and self._holding is None and pick.touch is None:
            # Fingers left closed (a dropped part) would come down on the part: found by the
            # chaos soak, where the next pick after a drop and a resume "missed".
            not_ready = self._gripper.ready_to_grasp()
            if not_ready is not None:
                raise SafetyRefusal(not_ready)
        if pick.refused:
            outcome["refused"] = [asdict(r) for r in pick.refused]
        pick.place_index = self._place_index if _has_place(chosen.steps) else None
        self.progress.say("planned: " + describe_plan(chosen.plan))
        self.progress.say(f"pre-flight: {len(chosen.checks)} checks passed")
        detection = pick.detections[chosen.index]
        record = plan_record(self.config, self.calibration, detection, chosen.plan, capture.source)
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
        )

    def _tell_candidates(
        self,
        plans: Sequence[PickPlan],
        chosen: int | None,
        refused: Sequence[CandidateRefusal],
    ) -> None:
        if self._observer is not None:
            self._observer.on_candidates(plans, chosen, refused)

    def _finish_pick(self, pick: _PickRun, done: Executed | None) -> dict[str, object]:
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
        elif pick.place_index is not None:
            self._place_index += 1
            pick.status = Status.PLACED
        else:
            pick.status = Status.PICKED
        if done is not None:  # a part picked and not placed is carried until a place releases it
            self._holding = done.grasp if pick.status is Status.PICKED else None
        return {
            "status": pick.status,
            "candidate": chosen.index,
            "errors": {name: asdict(error) for name, error in pick.errors.items()},
        }

    def _next_place_pose(self, place: PlaceConfig) -> Transform:
        """The place pose ``T_base_tcp`` (m) the next place uses (they are used in turn)."""
        return place.T_base_tcp[self._place_index % len(place.T_base_tcp)]

    def _run_fixed(
        self,
        steps: list[Step],
        what: str,
        request_id: str | None,
        record: dict[str, object],
    ) -> dict[str, Transform]:
        """A sequence of configured targets (place poses, named poses) through ``_run``; a
        carried part is watched on every move."""
        reached: dict[str, Transform] = {}

        def prepare(
            T_flange_tcp: Transform, context: dict[str, object], outcome: dict[str, object]
        ) -> Planned:
            # Where the arm stands is read only when corners are rounded (blend_mm > 0) or the
            # path is swept against a scene.
            swept = self.config.scene is not None
            T_base_tcp_start = (
                self.arm.tcp_pose() if self.config.motion.blend_mm > 0 or swept else None
            )
            rounded = (
                blended(self.config, steps, T_base_tcp_start)
                if T_base_tcp_start is not None
                else steps
            )
            checks = check_steps(
                self.config, rounded, self.arm, self._fixed_verdicts, T_base_tcp_start
            )
            if T_base_tcp_start is not None:
                checks = with_scene_checks(
                    self.config, rounded, T_base_tcp_start, T_flange_tcp, checks
                )
            plan = {"operation": what, "config": str(self.config.path)}
            return Planned(
                rounded, checks, {**plan, "host": self.config.robot.host}, T_base_tcp_start
            )

        def finish(done: Executed | None) -> dict[str, object]:
            if done is not None:
                reached.update(done.reached)
            return {"status": Status.DONE}

        self._run(
            {"cycle": self._cycle, "request_id": request_id, **record},
            prepare,
            finish,
            outcome_fields={"operation": what},
            holding=self._holding,
        )
        return reached

    def _run(
        self,
        context: dict[str, object],
        prepare: Prepare,
        finish: Finish,
        *,
        outcome_fields: dict[str, object],
        dry_run: bool = False,
        before_move: Callable[[str], None] | None = None,
        holding: GraspState | None = None,
    ) -> str:
        """The one skeleton every motion sequence runs; returns its pick id.

        In order: a new pick id in the audit; the halt guard; readiness (the controller, the
        session's program, the active TCP offset); ``prepare`` (plan and pre-flight, which
        refuse before anything moved); the plan record on disk; the steps (none for a dry run);
        the outcome record with ``finish``'s status. The outcome is appended whatever the
        ending, and a robot error halts the cell (``_halt_on_fault``). ``context`` goes into
        both records; ``holding`` is a part already carried, watched on every move.
        """
        audit = self._next_audit()
        self.last_pick_id = audit.pick_id
        outcome: dict[str, object] = {"event": "outcome", **context, **outcome_fields}
        self._tell_status({"pick_id": audit.pick_id, **context, **outcome_fields})
        with self._told_after(), self._halt_on_fault(), audited_outcome(audit, outcome):
            ensure_not_halted(self.config.robot.host, self._halted)
            planned = prepare(self._ready_tcp_offset(), context, outcome)
            audit.append(
                {
                    "event": "plan",
                    **context,
                    **planned.record,
                    "targets": steps_record(planned.steps),
                    **blends_record(planned.steps),
                    "checks": [asdict(check) for check in planned.checks],
                }
            )
            if self._observer is not None:
                self._observer.on_plan(planned.steps, planned.T_base_tcp_start)
            done = None
            if not dry_run:
                done = execute(
                    self.config,
                    planned.steps,
                    self.arm,
                    self.progress,
                    outcome,
                    before_move,
                    self._gripper,
                    holding,
                    self._watch,
                )
            outcome.update(finish(done))
        return audit.pick_id

    def _ready_tcp_offset(self) -> Transform:
        """Refuse an unready cell (every problem listed); the active TCP offset when ready."""
        T_flange_tcp = self.arm.tcp_offset()
        ensure_ready(self.arm.status(), T_flange_tcp, self.config.robot)
        return T_flange_tcp

    @contextmanager
    def _told_after(self) -> Iterator[None]:
        """The observer hears the state a sequence left, however it ended."""
        try:
            yield
        finally:
            self._tell_status()

    @contextmanager
    def _halt_on_fault(self) -> Iterator[None]:
        """A robot error halts the cell (the adapter has stopped the arm); a lost link also ends
        the robot session, so ``resume`` starts a fresh one."""
        try:
            yield
        except RobotError as exc:
            # A stop request halted the cell already, with who asked for it.
            if not (isinstance(exc, StopRequested) and self._halted is not None):
                self._halted = f"{type(exc).__name__}: {exc}"
            if isinstance(exc, RobotConnectionError):
                self._close_arm()
            raise


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

    def required_chosen(self) -> Chosen:
        if self.chosen is None:  # _run calls finish only after prepare chose
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
        )


def _named_move(pose: NamedPose) -> Step:
    if pose.q_rad is not None:
        return JointMove(pose.name, pose.q_rad)
    if pose.T_base_tcp is None:  # the config loader allows exactly one of the two
        raise ConfigError(f"pose {pose.name!r} has neither joints nor a TCP pose")
    return Move(pose.name, pose.T_base_tcp, fixed=True)


def _has_place(steps: Sequence[Step]) -> bool:
    return any(isinstance(step, Move) and step.name == PLACE for step in steps)


def _place_pose(steps: Sequence[Step]) -> Transform | None:
    for step in steps:
        if isinstance(step, Move) and step.name == PLACE:
            return step.T_base_tcp
    return None
