"""What one cell session knows between its operations, and the rules every operation keeps:
the halt (why, and what ends it), the readiness check, and what the observer hears.

A robot fault stops the arm (the adapter does that) and halts the cell: every motion is then
refused with ``CellHalted`` until ``Cell.resume``, after the operator cleared the cause on the
pendant. Nothing here unlocks, reconnects or re-sends by itself.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

from handeye_pick.audit import AuditLog
from handeye_pick.cell.ahead import Ahead
from handeye_pick.cell.captures import CaptureBook
from handeye_pick.cell.link import Link
from handeye_pick.cell.observer import Contained
from handeye_pick.cell.plan import CandidateRefusal, PickPlan
from handeye_pick.cell.sequence import SequenceWatch
from handeye_pick.config.schema import CellConfig, PlaceConfig
from handeye_pick.errors import RobotConnectionError, RobotError, StopRequested
from handeye_pick.geometry import Transform
from handeye_pick.gripper import GraspState
from handeye_pick.hand_eye.files import HandEyeCalibration
from handeye_pick.progress import Progress
from handeye_pick.safety import ControllerVerdicts, ensure_not_halted, ensure_ready
from handeye_pick.steps import Step


@dataclass(eq=False)
class CellState:
    """The state one ``Cell`` shares between its rooms (capture, pick, configured moves).

    ``cycle`` counts captures and picks without one; ``place_index`` picks the next place pose
    (they are used in turn); ``holding`` is a part picked and not yet placed; ``fixed_verdicts``
    the controller's verdicts on configured targets, kept for the session; ``latest_audit`` the
    audit log of the latest operation (a connect, a pick, a move), whatever its ending.
    """

    config: CellConfig
    calibration: HandEyeCalibration
    progress: Progress
    link: Link
    observer: Contained | None
    watch: SequenceWatch
    halted: str | None = None
    cycle: int = 0
    place_index: int = 0
    holding: GraspState | None = None
    fixed_verdicts: ControllerVerdicts = field(default_factory=dict)
    captures: CaptureBook = field(default_factory=CaptureBook)
    latest_audit: AuditLog | None = None
    running_steps: list[Step] = field(default_factory=list)  # the sequence running, if any
    ahead: Ahead | None = None  # the next pick, checked while the running sequence moves

    @property
    def host(self) -> str:
        return self.config.robot.host

    @property
    def last_pick_id(self) -> str | None:
        """The pick id of the latest operation's audit records, whatever its ending; None when
        that operation has no record on disk (none yet, or a write that failed)."""
        audit = self.latest_audit
        return audit.pick_id if audit is not None and audit.records_written > 0 else None

    def next_operation(self) -> AuditLog:
        """The audit log of a new operation (connect, pick, move), now the latest one."""
        return self.made_latest(self.link.next_audit())

    def record_ahead(self, *, wait: bool) -> None:
        """The plan record of the pick checked ahead, once its check is done (``wait``: wait
        for it); never raises (``cell.ahead``)."""
        if self.ahead is not None:
            self.ahead.record(self.link.next_audit, wait)

    def made_latest(self, audit: AuditLog) -> AuditLog:
        """``audit`` (an operation's log made earlier: a pick checked ahead), now the latest."""
        self.latest_audit = audit
        return audit

    def ensure_not_halted(self) -> None:
        """CellHalted (why, and how to end it) while the cell is halted."""
        ensure_not_halted(self.host, self.halted)

    def ready_tcp_offset(self) -> Transform:
        """Refuse an unready cell (every problem listed); the active TCP offset
        ``T_flange_tcp`` (m) when ready."""
        arm = self.link.arm
        T_flange_tcp = arm.tcp_offset()
        ensure_ready(arm.status(), T_flange_tcp, self.config.robot)
        return T_flange_tcp

    def path_start_s(self) -> float:
        """What starting a blended path costs on the connected controller (s, the arm's running
        figure); 0 while it has none (nothing measured: corners are kept wherever they save)."""
        figure = self.link.arm.path_start_s()
        return 0.0 if figure is None else figure

    def next_place_pose(self, place: PlaceConfig) -> Transform:
        """The place pose ``T_base_tcp`` (m) the next place uses (they are used in turn)."""
        return place.T_base_tcp[self.place_index % len(place.T_base_tcp)]

    @contextmanager
    def halt_on_fault(self) -> Iterator[None]:
        """A robot error halts the cell (the adapter has stopped the arm); a lost link also ends
        the robot session, so ``resume`` starts a fresh one."""
        try:
            yield
        except RobotError as exc:
            # A stop request halted the cell already, with who asked for it.
            if not (isinstance(exc, StopRequested) and self.halted is not None):
                self.halted = f"{type(exc).__name__}: {exc}"
            if isinstance(exc, RobotConnectionError):
                self.link.close_robot()
            raise

    @contextmanager
    def told_after(self) -> Iterator[None]:
        """The observer hears the state an operation left, however it ended."""
        try:
            yield
        finally:
            self.tell_status()

    def tell_status(self, running: dict[str, object] | None = None) -> None:
        """The observer hears the session's state: running (``running`` says what), halted
        (and why) or idle."""
        if self.observer is None:
            return
        if running is not None:
            status: dict[str, object] = {"state": "running", **running}
        elif self.halted is not None:
            status = {"state": "halted", "halted_reason": self.halted}
        else:
            status = {"state": "idle"}
        self.observer.on_status({"host": self.host, **status})

    def tell_candidates(
        self,
        plans: Sequence[PickPlan],
        chosen: int | None,
        refused: Sequence[CandidateRefusal],
    ) -> None:
        """The observer hears every candidate's plan, the chosen one and the refusals."""
        if self.observer is not None:
            self.observer.on_candidates(plans, chosen, refused)
