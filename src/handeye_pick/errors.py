"""Typed errors of handeye-pick.

One root, one subclass per kind of failure. The CLI maps each kind to one exit status, so the
class a function raises is part of its contract:

- ``InputError`` (exit 2): a file, a config key or an argument is wrong; nothing was sent.
- ``SafetyRefusal`` (exit 3): a pre-flight check refused, or the cell is not ready; nothing moved.
- ``RobotError`` (exit 4): the robot or the link to it failed, possibly during motion.

Every message names the operation, what was expected and what was found.
"""

from __future__ import annotations


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


class Terminated(KeyboardInterrupt):
    """SIGTERM (a supervisor, systemd) arrived: handled exactly like Ctrl-C (stop the arm, write
    the outcome), then exit status 143 instead of 130."""
