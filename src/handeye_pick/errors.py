"""Typed errors of handeye-pick, the statuses an operation ends in, and the one table between.

One root, one subclass per kind of failure. ``ending`` maps each kind to the status an audit
outcome (and every ``--json`` report) records, the status a ``run`` reply carries and the exit
status of a command, so the class a function raises is part of its contract:

- ``InputError`` (exit 2): a file, a config key or an argument is wrong; nothing was sent.
- ``SafetyRefusal`` (exit 3): a pre-flight check refused, or the cell is not ready; nothing moved.
- ``RobotError`` (exit 4): the robot or the link to it failed, possibly during motion.

Every message names the operation, what was expected and what was found.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum, IntEnum


class Status(str, Enum):
    """Every status an audit outcome, a ``run`` reply or a ``--json`` report carries."""

    # an operation that ran to its end
    PLACED = "placed"
    PICKED = "picked"
    MISSED = "missed"  # the gripper closed on nothing, opened, and the arm retreated
    DRY_RUN = "dry-run"
    DONE = "done"  # a place or a named-pose move (audit)
    MOVED = "moved"  # a named-pose move (reply)
    CAPTURED = "captured"
    READY = "ready"
    NOT_READY = "not-ready"
    BYE = "bye"
    STOPPED = "stopped"  # run's stop request braked the arm
    BUSY = "busy"  # run: the status of a cell while a request runs
    # an operation that did not
    BAD_INPUT = "bad-input"
    BAD_REQUEST = "bad-request"
    REFUSED = "refused"
    NO_CANDIDATE = "no-candidate"
    HALTED = "halted"
    HELD = "held"  # run: a cycle stop holds the cell; the request was not run (docs/line.md)
    DROPPED = "dropped"
    ABORTED = "aborted"  # refused after the arm had moved: it stands where it stopped
    FAULT = "fault"
    INTERRUPTED = "interrupted"
    ERROR = "error"  # a defect, not a failure this package knows

    def __str__(self) -> str:
        return self.value


class ExitCode(IntEnum):
    """The exit statuses of every command."""

    OK = 0
    INTERNAL = 1  # a defect in handeye-pick
    BAD_INPUT = 2
    REFUSED = 3  # refused by a check, or the cell not ready; nothing moved
    ROBOT_FAULT = 4
    MISSED = 5  # pick: the gripper closed on nothing, opened, and the arm retreated
    INTERRUPTED = 130  # Ctrl-C, after stopL
    TERMINATED = 143  # SIGTERM, handled exactly like Ctrl-C


class HandEyePickError(Exception):
    """Root of every error this package raises on purpose."""


class InputError(HandEyePickError):
    """Bad input: a file, a config value, a command-line argument (exit status 2)."""


class ConfigError(InputError):
    """The cell configuration is invalid; the message names the key."""


class CalibrationError(InputError):
    """A hand-eye or robot pose file cannot be read or holds an implausible transform."""


class TransformError(InputError):
    """A 4x4 matrix is not a rigid transform (shape, finiteness, bottom row, rotation)."""


class DetectionError(InputError):
    """A camera-frame detection (file, point, pixel in a cloud) is missing or invalid."""


class SafetyRefusal(HandEyePickError):
    """A pre-flight check refused the plan, or the cell is not ready; nothing moved (exit 3)."""


class CellHalted(SafetyRefusal):
    """A fault halted the cell: motion is refused until the operator clears it and resumes."""


class RobotError(HandEyePickError):
    """The robot or the connection to it failed (exit status 4)."""


class RobotConnectionError(RobotError):
    """Could not connect, or the connection dropped."""


class RobotFault(RobotError):
    """The controller refused or aborted a command (protective stop, stopped program, timeout).

    Carries the controller state read right after the failure, so the message can say why.
    """

    def __init__(
        self,
        message: str,
        *,
        safety_mode: int | None = None,
        runtime_state: int | None = None,
        robot_mode: int | None = None,
    ) -> None:
        super().__init__(message)
        self.safety_mode = safety_mode
        self.runtime_state = runtime_state
        self.robot_mode = robot_mode


class GripperFault(RobotError):
    """The gripper reports a fault, does not answer in time, or did not do what it was told."""


class PartDropped(RobotError):
    """A part confirmed in the gripper was lost while the arm carried it; the arm was stopped."""


class SequenceAborted(RobotError):
    """A check refused a step after the sequence had already moved the arm: it stands where it
    stopped, not where it started, so this is a fault (exit 4, the cell halts), not a refusal."""


class StopRequested(RobotError):
    """An operator's ``stop`` request (``run``) braked the arm mid-sequence with stopL; the cell
    is halted until ``resume``, as after a fault the operator asked for."""


class Terminated(KeyboardInterrupt):
    """SIGTERM (a supervisor, systemd) arrived: handled exactly like Ctrl-C (stop the arm, write
    the outcome), then exit status 143 instead of 130."""


class PlanRefused(SafetyRefusal):
    """No candidate of a pick passed every pre-flight check; nothing moved (a reply says
    ``no-candidate``)."""


@dataclass(frozen=True)
class Ending:
    """How an operation that raised ends: its outcome status (audit record, ``--json`` report),
    its reply status (``run``) and the exit status of a command."""

    outcome: Status
    reply: Status
    exit_code: ExitCode


_ENDINGS: tuple[tuple[type[BaseException], Ending], ...] = (  # the first matching row wins
    (Terminated, Ending(Status.INTERRUPTED, Status.INTERRUPTED, ExitCode.TERMINATED)),
    (KeyboardInterrupt, Ending(Status.INTERRUPTED, Status.INTERRUPTED, ExitCode.INTERRUPTED)),
    (CellHalted, Ending(Status.HALTED, Status.HALTED, ExitCode.REFUSED)),
    (PlanRefused, Ending(Status.REFUSED, Status.NO_CANDIDATE, ExitCode.REFUSED)),
    (SafetyRefusal, Ending(Status.REFUSED, Status.REFUSED, ExitCode.REFUSED)),
    (PartDropped, Ending(Status.DROPPED, Status.DROPPED, ExitCode.ROBOT_FAULT)),
    (SequenceAborted, Ending(Status.ABORTED, Status.ABORTED, ExitCode.ROBOT_FAULT)),
    (StopRequested, Ending(Status.STOPPED, Status.STOPPED, ExitCode.ROBOT_FAULT)),
    (RobotError, Ending(Status.FAULT, Status.FAULT, ExitCode.ROBOT_FAULT)),
    (InputError, Ending(Status.BAD_INPUT, Status.BAD_REQUEST, ExitCode.BAD_INPUT)),
)
_DEFECT = Ending(Status.ERROR, Status.ERROR, ExitCode.INTERNAL)


def ending(exc: BaseException) -> Ending:
    """The one table from an exception to its statuses and exit code."""
    for kind, end in _ENDINGS:
        if isinstance(exc, kind):
            return end
    return _DEFECT
