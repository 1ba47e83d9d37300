"""The small interface the pick talks to for any gripper kind.

A gripper closes on a part, opens, and says what it senses. Widths are between the fingers in
millimetres; times in seconds. Every method either does what it says or raises ``GripperFault``
(a ``RobotError``): a fault the gripper reports, no answer within its timeout, a release it
sensed did not happen. Nothing returns a silent failure.
"""

from __future__ import annotations

import enum
from typing import Protocol


class GraspState(enum.Enum):
    """What a gripper senses about the part between its fingers."""

    CONFIRMED = "confirmed"  # a part is sensed in the gripper
    MISSED = "missed"  # the gripper senses no part (closed on nothing, or the part was lost)
    UNCONFIRMED = "unconfirmed"  # the gripper cannot tell (no feedback)


class Gripper(Protocol):
    """A connected gripper; opened with the cell's robot session, closed with it."""

    kind: str  # the config's robot.gripper.type

    def close(self) -> GraspState:
        """Close on the part and wait until the fingers (or suction) settle; the sensed state."""
        ...

    def why_missed(self) -> str:
        """Why the last ``close`` sensed no part, in one clause an operator can act on: what the
        gripper waited for (which input at which level, or which finger width), for how long,
        and what to check."""
        ...

    def open(self) -> bool:
        """Open and wait until done; True when the release is sensed (the part left the
        gripper), False when the gripper cannot tell. GripperFault when it senses the part is
        still held."""
        ...

    def ready_to_grasp(self) -> str | None:
        """None when the gripper may come down over a part (open, as far as it can sense);
        otherwise why not, in one line. Moves nothing."""
        ...

    def state(self) -> GraspState:
        """The grasp as sensed now, moving nothing (cheap enough to poll during a move)."""
        ...

    def close_connection(self) -> None:
        """Release whatever the gripper holds open (a socket); safe to call twice."""
        ...
