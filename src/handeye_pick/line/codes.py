"""The last error as the line sees it: a stable number a PLC or a panel can switch on, and one
line of text for a person.

The number is the exit status a command would end with, times 100, plus the status's place
within that exit status (docs/line.md has the table); 0 means no error since ``run`` started.
The numbers never change meaning: a new status gets a new number.
"""

from __future__ import annotations

from dataclasses import dataclass

ERROR_CODES: dict[str, int] = {
    "error": 100,  # a defect in handeye-pick (exit 1)
    "bad-input": 200,  # bad input (exit 2)
    "refused": 301,  # a check refused, or the cell was not ready: nothing moved (exit 3)
    "no-candidate": 302,  # no candidate passed every check: nothing moved
    "halted": 303,  # refused: the cell stood halted by an earlier fault or stop
    "not-ready": 304,  # a resume refused: the controller is not ready yet
    "fault": 401,  # a robot fault stopped the arm; the cell halts (exit 4)
    "dropped": 402,  # a part slipped out of the gripper; the arm was stopped
    "aborted": 403,  # a check refused a step after the arm had moved
    "stopped": 404,  # an immediate stop braked the arm
    "missed": 501,  # the gripper closed on nothing, opened, the arm retreated (exit 5)
    "abandoned": 901,  # a pick left unfinished by a killed process, closed at the next start
    "interrupted": 1300,  # Ctrl-C or SIGTERM ended the session (exit 130 or 143)
}
"""Status -> error code. A status not listed (a newer one) reads as ``UNKNOWN_CODE``."""
UNKNOWN_CODE = 999
NO_ERROR = 0
MAX_TEXT_CHARS = 200
"""Longest error text passed on: a panel shows one line."""


@dataclass(frozen=True)
class LineError:
    """The last error: its code (``ERROR_CODES``), its status and one line of text."""

    code: int
    status: str
    text: str


NONE = LineError(NO_ERROR, "", "")


def line_error(status: str, text: str) -> LineError:
    """The error for ``status`` with ``text`` cut to one line of at most ``MAX_TEXT_CHARS``."""
    first = text.strip().splitlines()[0] if text.strip() else status
    if len(first) > MAX_TEXT_CHARS:
        first = first[: MAX_TEXT_CHARS - 3] + "..."
    return LineError(ERROR_CODES.get(status, UNKNOWN_CODE), status, first)
