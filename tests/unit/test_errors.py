"""The one table from an error to its statuses and exit code (errors.ending)."""

from __future__ import annotations

import json

import pytest

from handeye_pick.cell.plan import NoFeasibleCandidate
from handeye_pick.errors import (
    CalibrationError,
    CellHalted,
    ConfigError,
    ExitCode,
    GripperFault,
    InputError,
    PartDropped,
    RobotConnectionError,
    RobotFault,
    SafetyRefusal,
    SequenceAborted,
    Status,
    StopRequested,
    Terminated,
    ending,
)
from handeye_pick.safety import CheckResult, PreflightRefusal

REFUSED_CHECK = [CheckResult("workspace", "grasp", False, "outside")]


@pytest.mark.parametrize(
    ("exc", "outcome", "reply", "exit_code"),
    [
        (Terminated(), Status.INTERRUPTED, Status.INTERRUPTED, 143),
        (KeyboardInterrupt(), Status.INTERRUPTED, Status.INTERRUPTED, 130),
        (CellHalted("x"), Status.HALTED, Status.HALTED, 3),
        (PreflightRefusal(REFUSED_CHECK), Status.REFUSED, Status.NO_CANDIDATE, 3),
        (NoFeasibleCandidate([]), Status.REFUSED, Status.NO_CANDIDATE, 3),
        (SafetyRefusal("x"), Status.REFUSED, Status.REFUSED, 3),
        (PartDropped("x"), Status.DROPPED, Status.DROPPED, 4),
        (SequenceAborted("x"), Status.ABORTED, Status.ABORTED, 4),
        (StopRequested("x"), Status.STOPPED, Status.STOPPED, 4),
        (RobotFault("x"), Status.FAULT, Status.FAULT, 4),
        (RobotConnectionError("x"), Status.FAULT, Status.FAULT, 4),
        (GripperFault("x"), Status.FAULT, Status.FAULT, 4),
        (InputError("x"), Status.BAD_INPUT, Status.BAD_REQUEST, 2),
        (ConfigError("x"), Status.BAD_INPUT, Status.BAD_REQUEST, 2),
        (CalibrationError("x"), Status.BAD_INPUT, Status.BAD_REQUEST, 2),
        (ValueError("a defect"), Status.ERROR, Status.ERROR, 1),
    ],
)
def test_every_error_kind_has_its_statuses_and_exit_code(
    exc: BaseException, outcome: Status, reply: Status, exit_code: int
) -> None:
    end = ending(exc)
    assert (end.outcome, end.reply, end.exit_code) == (outcome, reply, exit_code)


def test_statuses_serialise_as_their_plain_strings() -> None:
    assert json.dumps({"status": Status.NO_CANDIDATE}) == '{"status": "no-candidate"}'
    assert f"{Status.DRY_RUN}" == "dry-run"
    assert len({s.value for s in Status}) == len(Status)
    assert ExitCode.TERMINATED == 143
