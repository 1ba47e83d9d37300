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

This class is the table of contents; each concern has its own room in ``cell/``:

- ``link.py``: the lock, the audit file, the robot session and the gripper;
- ``state.py``: what the session knows between operations, the halt, readiness, the observer;
- ``operation.py``: the one skeleton every motion runs (halt guard, readiness, pre-flight, the
  plan on disk before the first motion command, the moves, the outcome whatever the ending);
- ``capturing.py``: captures latched or given; ``pick.py``: picks and touch tests;
  ``moves.py``: moves to configured targets (named poses, the place, the capture pose);
- ``status.py``: the state read for ``status``, from the session or from outside.

A robot fault stops the arm (the adapter does that) and halts the cell: every motion is then
refused with ``CellHalted`` until ``resume()``, after the operator cleared the cause on the
pendant. Nothing is ever unlocked, reconnected or re-sent by itself.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from types import TracebackType

from handeye_pick.cell import capturing, moves
from handeye_pick.cell.ahead import AheadRequest
from handeye_pick.cell.captures import Capture
from handeye_pick.cell.link import ArmFactory, Link, connect_ur_rtde
from handeye_pick.cell.observer import CellObserver, Contained
from handeye_pick.cell.pick import PickResult, TouchTest, look, run_pick
from handeye_pick.cell.plan import PickPlan, chain_plan, check_steps
from handeye_pick.cell.sequence import SequenceWatch
from handeye_pick.cell.state import CellState
from handeye_pick.cell.status import (
    CellStatus,
    flange_from_outside,
    halted_without_link,
    outside_status,
    session_status,
    unread,
)
from handeye_pick.config.hand_eye import calibration_from_config
from handeye_pick.config.load import load_config
from handeye_pick.config.schema import CellConfig, NamedPose
from handeye_pick.detection import Detection
from handeye_pick.errors import SafetyRefusal, Status
from handeye_pick.geometry import Transform
from handeye_pick.hand_eye.files import HandEyeCalibration
from handeye_pick.progress import Progress
from handeye_pick.robot.port import RobotArm
from handeye_pick.safety import PreflightRefusal, workspace_problem
from handeye_pick.steps import Move

log = logging.getLogger(__name__)


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
        self.calibration: HandEyeCalibration = calibration_from_config(self.config)
        self.progress = progress if progress is not None else Progress.quiet()
        contained = Contained(observer, "recording") if observer is not None else None
        if contained is not None and connect is connect_ur_rtde:
            connect = functools.partial(connect_ur_rtde, on_sample=contained.on_sample)
        self._state = CellState(
            config=self.config,
            calibration=self.calibration,
            progress=self.progress,
            link=Link(
                self.config,
                connect,
                self.progress,
                contained.on_audit if contained is not None else None,
            ),
            observer=contained,
            # see watch_steps and request_stop
            watch=SequenceWatch(
                on_reached=contained.on_reached if contained is not None else None
            ),
        )

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
        nothing is opened or sent), open the audit file (appendable, locked, unfinished picks
        of a killed process closed as abandoned) before anything is sent, then the robot
        session; a failure to connect is audited (step ``connect``) and raised."""
        state = self._state
        state.link.open_audit()
        state.link.connect_robot(state.next_operation(), request_id)
        state.fixed_verdicts.clear()
        state.tell_status()

    def close(self) -> None:
        """Close the robot session and release the audit file; safe to call twice."""
        self._state.link.close()

    @property
    def arm(self) -> RobotArm:
        """The connected robot; RobotConnectionError when the session is closed or lost."""
        return self._state.link.arm

    @property
    def connected(self) -> bool:
        """Whether the robot session is open (False after a lost link, until ``resume``)."""
        return self._state.link.connected

    @property
    def halted(self) -> str | None:
        """Why the cell is halted (motion refused until ``resume``), or None."""
        return self._state.halted

    @property
    def last_pick_id(self) -> str | None:
        """The ``pick_id`` of the audit records of the latest operation (a connect, a pick, a
        move), whatever its ending, so a report of a failed pick carries it; None when that
        operation has no record on disk (refused before the audit file, or a failed write)."""
        return self._state.last_pick_id

    def watch_steps(self, on_step: Callable[[str], None]) -> None:
        """``on_step`` hears the name of each step of a running sequence as it starts (a blended
        path's waypoints included), on the thread that runs it."""
        self._state.watch = replace(self._state.watch, on_step=on_step)

    def look_ahead(self, waiting: Callable[[], AheadRequest | None]) -> None:
        """While a place runs, check the pick ``waiting`` names (the request in line after the
        running one, or None) on a second thread, from the pose the place ends at, and write
        its plan record; ``pick`` with that request's ``ahead_key`` runs it once the arm is
        confirmed where it was checked to start, or plans it again (``cell.ahead``)."""
        state = self._state
        state.watch = replace(state.watch, on_look=lambda step: look(state, step, waiting))

    def drop_ahead(self, key: str, status: Status, error: str) -> None:
        """The request ``key`` was checked ahead and is answered without running (``status``,
        ``error``): its audit records end with that outcome."""
        state = self._state
        ahead = state.ahead
        if ahead is None or ahead.request.key != key:
            return
        state.ahead = None
        ahead.wait()
        if ahead.audit is not None:
            ahead.audit.append(
                {
                    "event": "outcome",
                    "cycle": ahead.cycle,
                    "request_id": ahead.request.request_id,
                    "capture_id": ahead.capture.capture_id,
                    "dry_run": False,
                    "status": status,
                    "error": error,
                }
            )

    def request_stop(self, why: str = "stop requested") -> None:
        """Halt the cell now and brake a sequence in flight at its next look (every few
        milliseconds while the arm moves; before the next step otherwise): stopL, outcome
        ``stopped``. Safe to call from any thread; ``resume`` ends the halt."""
        state = self._state
        if state.halted is None:
            state.halted = why
        state.watch.stop.set()
        state.tell_status()

    def resume(self, *, request_id: str | None = None) -> CellStatus:
        """After the operator cleared a fault on the pendant: a fresh robot session, then the
        full readiness check. The cell stays halted (SafetyRefusal) while it is not ready.
        Each attempt that got as far as the readiness check is audited as a ``resume`` record
        (``status`` ready or not-ready, ``halted``: why the cell was halted), so the audit file
        alone says how long the cell stood."""
        state = self._state
        state.link.close_robot()
        self.connect(request_id=request_id)
        reason, state.halted = state.halted, None
        status = self.status()
        state.link.next_audit().append(
            {
                "event": "resume",
                "request_id": request_id,
                "status": Status.READY if status.ready else Status.NOT_READY,
                "halted": reason,
                "problems": status.problems,
            }
        )
        if not status.ready:
            state.halted = reason
            raise SafetyRefusal(
                f"cell on {self.config.robot.host} is still not ready, staying halted: "
                + "; ".join(status.problems)
            )
        # What the gripper holds after the operator's recovery is unknown: watch no part.
        state.holding = None
        state.watch.stop.clear()
        state.tell_status()
        log.warning("cell %s resumed (was halted: %s)", self.config.robot.host, reason)
        return status

    def note_cloud(self, path: Path, capture: Capture | None) -> None:
        """The vision program's point cloud of ``capture`` (a file, camera frame, mm), for the
        observer (a recording shows it); the cell itself never reads it."""
        if self._state.observer is not None:
            self._state.observer.on_cloud(path, capture)

    # --- reading -----------------------------------------------------------------------------

    def status(self) -> CellStatus:
        """Controller state, TCP offset against the config, poses, and every readiness problem
        (halted included). Reads only; works while halted. A cell halted by a lost link has no
        robot session left: it reads the controller from outside (``inspect``), so the operator
        still sees what the pendant would show."""
        state = self._state
        if state.link.connected:
            return session_status(state.link.arm, self.config, self.calibration, state.halted)
        if state.halted is None:
            return unread(["not connected"], None)
        return halted_without_link(self.config, self.calibration, state.halted, self.progress)

    def inspect(self) -> CellStatus:
        """The cell's state read from outside, for ``status`` (``cell.status.outside_status``):
        no program is started and nothing is written, so the controller is left exactly as it
        was found. Needs no ``connect``."""
        return outside_status(self.config, self.calibration, self._state.halted, self.progress)

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
        link = self._state.link
        if T_base_flange is not None:
            T_flange_tcp = self.config.robot.T_flange_tcp
        elif link.connected:
            T_flange_tcp = link.arm.tcp_offset()
            T_base_flange = link.arm.flange_pose()
        else:
            T_flange_tcp, T_base_flange = flange_from_outside(self.config, self.progress)
        return chain_plan(self.config, self.calibration, detection, T_base_flange, T_flange_tcp)

    def check_pose(self, T_base_tcp: Transform) -> list[str]:
        """Every pre-flight problem a moveL to ``T_base_tcp`` (m) would meet, moving nothing:
        workspace box, tilt, motion caps, the controller's safety limits and IK. Empty when
        the move would pass (``poses`` keeps only such targets)."""
        steps = [Move("target", T_base_tcp)]
        try:
            check_steps(self.config, steps, self.arm, self._state.fixed_verdicts)
        except PreflightRefusal as refusal:
            return [f"{r.name}: {r.detail}" for r in refusal.results if not r.passed]
        return []

    # --- capture (cell/capturing.py) ---------------------------------------------------------

    def capture(self, pose: str | None = None, *, request_id: str | None = None) -> Capture:
        """Start a cycle: move to the named ``pose`` (default ``capture.pose`` of the config)
        if any, wait until the arm is steady and latch ``T_base_flange`` from a fresh RTDE
        sample. Eye-to-hand latches no pose (the camera is fixed); its capture pose is meant to
        take the arm out of the camera's view, and one must be configured or given."""
        return capturing.capture(self._state, pose, request_id)

    def latch_flange_pose(self, *, request_id: str | None = None) -> Transform:
        """``T_base_flange`` (m) where the arm stands, in either mode, moving nothing: waits
        until the arm is steady and reads a fresh RTDE sample; audited as a ``capture``. A
        hand-eye dataset needs the flange pose in both modes (``collect``)."""
        return capturing.latch_flange_pose(self._state, request_id)

    def given_capture(self, T_base_flange: Transform, source: str) -> Capture:
        """Register a capture pose measured elsewhere (a detection file's ``capture``, Zivid's
        ``RobotTransform.yaml``, ``--capture-pose-ur``): ``T_base_flange`` (m) at acquisition."""
        return capturing.given_capture(self._state, T_base_flange, source)

    def find_capture(self, capture_id: str) -> Capture:
        """A capture of this session by id; InputError when unknown or forgotten."""
        return self._state.captures.find(capture_id)

    def request_capture(self, capture_id: str | None) -> Capture | None:
        """The capture a pick *request* of a running session uses (``run``): the one it names.
        Eye-to-hand needs none (None). Eye-in-hand must name one (InputError): in a session the
        arm moves between image and pick, so the flange read at pick time (what ``pick`` does
        with no capture, for the one-shot command) would not be the flange of the image."""
        return capturing.request_capture(self._state, capture_id)

    # --- motion (cell/pick.py, cell/moves.py) ------------------------------------------------

    def pick(
        self,
        candidates: Detection | Sequence[Detection],
        capture: Capture | None = None,
        *,
        place: bool = True,
        dry_run: bool = False,
        request_id: str | None = None,
        on_plan: Callable[[PickPlan], None] | None = None,
        ahead_key: str | None = None,
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
        ``ahead_key``: the request's key, when it may have been checked ahead (``look_ahead``).
        """
        detections = [candidates] if isinstance(candidates, Detection) else list(candidates)
        return run_pick(
            self._state,
            detections,
            capture,
            place=place,
            dry_run=dry_run,
            request_id=request_id,
            on_plan=on_plan,
            ahead_key=ahead_key,
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
        return run_pick(
            self._state,
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
        return moves.place(self._state, request_id)

    def move_to(self, pose: str | NamedPose, *, request_id: str | None = None) -> Transform:
        """Move to a named pose of the config, or to a ``NamedPose`` given directly (moveJ for
        joints, moveL for a TCP pose), checked and audited like any motion; returns the reached
        ``T_base_tcp``."""
        return moves.move_to(self._state, pose, request_id)
