"""The small interface the pick runner talks to; the ur_rtde adapter implements it.

Frames and units: every pose is a float64 4x4 transform in metres, named by the frames it relates
(``T_base_flange``, ``T_base_tcp``, ``T_flange_tcp``). Base is the controller's base frame as the
teach pendant shows it. Speeds are m/s and accelerations m/s^2 of the TCP.

Every method either does what it says or raises a ``RobotError`` subclass: a refusal or abort by
the controller is ``RobotFault`` (carrying safety mode and runtime state), a lost or impossible
link is ``RobotConnectionError``. No method returns a silent ``False``.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

from handeye_pick.geometry import Transform


class SafetyMode(enum.IntEnum):
    """UR ``safety_mode`` values (RTDE)."""

    NORMAL = 1
    REDUCED = 2
    PROTECTIVE_STOP = 3
    RECOVERY = 4
    SAFEGUARD_STOP = 5
    SYSTEM_EMERGENCY_STOP = 6
    ROBOT_EMERGENCY_STOP = 7
    VIOLATION = 8
    FAULT = 9


class RobotMode(enum.IntEnum):
    """UR ``robot_mode`` values (RTDE)."""

    NO_CONTROLLER = -1
    DISCONNECTED = 0
    CONFIRM_SAFETY = 1
    BOOTING = 2
    POWER_OFF = 3
    POWER_ON = 4
    IDLE = 5
    BACKDRIVE = 6
    RUNNING = 7
    UPDATING_FIRMWARE = 8


class RuntimeState(enum.IntEnum):
    """UR ``runtime_state`` values (RTDE)."""

    STOPPING = 0
    STOPPED = 1
    PLAYING = 2
    PAUSING = 3
    PAUSED = 4
    RESUMING = 5


def mode_name(enum_type: type[enum.IntEnum], value: int) -> str:
    """Name of a UR mode value for messages, e.g. ``PROTECTIVE_STOP``; ``unknown (42)`` for a value
    this enum does not list (newer firmware)."""
    try:
        return enum_type(value).name
    except ValueError:
        return f"unknown ({value})"


class OutputBank(enum.Enum):
    """A bank of digital outputs or inputs a gripper is wired to."""

    STANDARD = "standard"
    TOOL = "tool"


@dataclass(frozen=True)
class RobotStatus:
    """Controller state read from one fresh RTDE sample (and the dashboard for remote control)."""

    controller_version: str
    robot_mode: int
    safety_mode: int
    runtime_state: int
    remote_control: bool
    protective_stopped: bool
    emergency_stopped: bool


ProgressCallback = Callable[[float], None]
"""Called while a motion runs with the fraction of it done, 0.0 to 1.0 (best estimate). For a
path of n waypoints the fraction lies in [k/n, (k+1)/n) while the arm heads for waypoint k."""

SampleListener = Callable[[Sequence[float], float], None]
"""Hears every RTDE sample an arm reads: ``actual_TCP_pose`` (UR vector, m and rad, base frame)
and the controller's ``timestamp`` (s since the controller started). Must not raise."""


@dataclass(frozen=True)
class Waypoint:
    """One target of a blended moveL path: ``T_base_tcp`` (m), the speed (m/s) and acceleration
    (m/s^2) of the segment that leads to it, and the radius (m) its corner is rounded with."""

    T_base_tcp: Transform
    speed_mps: float
    accel_mps2: float
    blend_m: float


class RobotArm(Protocol):
    """A connected UR arm. Connections are opened once per session by the adapter's constructor
    or context manager, not per call."""

    def status(self) -> RobotStatus:
        """Current controller state. Does not block beyond one RTDE cycle."""
        ...

    def remote_control(self) -> bool:
        """Whether the pendant is in Remote Control, so the controller takes this session's
        commands; True on a controller without such a mode (CB3, PolyScope before 5.6). One
        dashboard round trip."""
        ...

    def tcp_offset(self) -> Transform:
        """``T_flange_tcp`` (m): the TCP offset active on the controller right now."""
        ...

    def tcp_pose(self) -> Transform:
        """``T_base_tcp`` (m) from an RTDE sample newer than this call."""
        ...

    def flange_pose(self) -> Transform:
        """``T_base_flange`` (m) from an RTDE sample newer than this call.

        Derived from ``actual_TCP_pose`` and the active TCP offset; never from ur_rtde's
        ``getActualToolFlangePose``, whose first call returns stale values in 1.6.5.
        """
        ...

    def steady_flange_pose(self, timeout_s: float) -> Transform:
        """``T_base_flange`` (m) latched from a fresh RTDE sample while the arm is at rest
        (every joint still); RobotFault when it does not come to rest within ``timeout_s``."""
        ...

    def joint_positions(self) -> tuple[float, ...]:
        """The six joint positions (rad) from the latest RTDE sample."""
        ...

    def joints_within_safety_limits(self, q_rad: Sequence[float]) -> bool:
        """The controller's own verdict on a joint target (joint limits, safety planes)."""
        ...

    def is_pose_within_safety_limits(self, T_base_tcp: Transform) -> bool:
        """The controller's own verdict on a TCP target (safety planes, joint limits)."""
        ...

    def has_ik_solution(self, T_base_tcp: Transform) -> bool:
        """Whether the controller finds an inverse-kinematics solution for a TCP target."""
        ...

    def path_start_s(self) -> float | None:
        """What starting a blended path costs on this controller beyond a single moveL (s): a
        running figure over the paths sent so far and the measurement of
        ``measure_path_start``; None before either."""
        ...

    def measure_path_start(self) -> float:
        """Measure what starting a program costs on this controller, without moving the arm
        (the arm must be at rest, no motion running); the new figure (s)."""
        ...

    def move_linear(
        self,
        T_base_tcp: Transform,
        speed_mps: float,
        accel_mps2: float,
        timeout_s: float,
        on_progress: ProgressCallback | None = None,
    ) -> Transform:
        """moveL to ``T_base_tcp``; blocks until it is reached and returns the reached
        ``T_base_tcp``. Runs asynchronously under the hood while watching safety status and the
        link; raises RobotFault (stopped, refused, timed out: the arm was told to stop) or
        RobotConnectionError. Interruptible by KeyboardInterrupt, which propagates after a stopL.

        ``timeout_s`` is the longest the move may take at full speed; the pendant's speed slider
        stretches it in wall-clock time."""
        ...

    def move_path(
        self,
        waypoints: Sequence[Waypoint],
        timeout_s: float,
        on_progress: ProgressCallback | None = None,
    ) -> Transform:
        """One blended moveL path through ``waypoints`` (the last one's radius is 0: the arm
        stops there), watched and stopped exactly as ``move_linear``; returns the reached
        ``T_base_tcp`` at the last waypoint. ``timeout_s`` bounds the whole path."""
        ...

    def move_joints(
        self,
        q_rad: Sequence[float],
        speed_rps: float,
        accel_rps2: float,
        timeout_s: float,
        on_progress: ProgressCallback | None = None,
    ) -> Transform:
        """moveJ to the joint positions ``q_rad`` (rad) at ``speed_rps`` / ``accel_rps2``,
        watched and stopped (stopJ) exactly as ``move_linear``; returns the reached
        ``T_base_tcp``."""
        ...

    def stop_linear(self, decel_mps2: float) -> None:
        """stopL with the given deceleration; best effort, never raises for a dead link."""
        ...

    def set_digital_output(self, bank: OutputBank, index: int, value: bool) -> None:
        """Set one digital output (gripper); raises RobotFault if the controller refuses."""
        ...

    def digital_input(self, bank: OutputBank, index: int) -> bool:
        """One digital input (a gripper's feedback) from the latest RTDE sample."""
        ...

    def set_payload(self, mass_kg: float, cog_flange_m: Sequence[float]) -> None:
        """UR's ``set_payload``: mass (kg) and centre of gravity (m, tool flange frame); raises
        RobotFault if the controller refuses."""
        ...

    def close(self) -> None:
        """Disconnect every interface. Safe to call twice."""
        ...
