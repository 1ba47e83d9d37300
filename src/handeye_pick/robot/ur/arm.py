"""RobotArm over ur_rtde 1.6.5, with ur_rtde contained in a child process (robot/ur/child.py).

One ``URRtdeArm`` is one session: one dashboard connection (robot/ur/dashboard.py: the PolyScope
version, and Remote Control before ur_rtde connects and whenever asked) + receive + control
interfaces (+ IO when a gripper output is configured), opened once by the constructor and closed
by ``close()`` or the ``with`` block. Every ur_rtde result is checked: a ``False`` becomes
``RobotFault`` carrying the controller's safety mode, runtime state and robot mode; a lost link, a
dead child or a call that does not answer in time becomes ``RobotConnectionError``, after which
the session is dead and the program is stopped through fresh dashboard connections. A dashboard
that stops answering ends the session too, the arm stopped through RTDE. It never reconnects and
never re-issues a motion. What the failures mean for the operator is robot/ur/advice.py.

Frames and units as in robot/port.py: 4x4 float64 transforms in metres; ``T_base_tcp`` includes
the controller's active TCP offset; ``T_base_flange = T_base_tcp @ inv(T_flange_tcp)``.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import TracebackType

import numpy as np

from handeye_pick.arm.models import ArmModel
from handeye_pick.errors import RobotConnectionError, RobotError, RobotFault, SafetyRefusal
from handeye_pick.geometry import (
    Transform,
    invert,
    rotation_angle_between,
    ur_pose_list,
    ur_pose_to_matrix,
)
from handeye_pick.limits import JOINT_STOP_DECEL_RPS2
from handeye_pick.robot.port import (
    OutputBank,
    ProgressCallback,
    RobotMode,
    RobotStatus,
    RuntimeState,
    SafetyMode,
    SampleListener,
    Waypoint,
    mode_name,
)
from handeye_pick.robot.ur.advice import connect_dashboard, dashboard_lost_error
from handeye_pick.robot.ur.child import Child
from handeye_pick.robot.ur.dashboard import stop_program_until_confirmed
from handeye_pick.robot.ur.worker import Sample

log = logging.getLogger(__name__)

POLL_PERIOD_S = 0.004
"""How often a running move is watched: two RTDE cycles at 500 Hz."""
REACHED_TOLERANCE_M = 0.001
REACHED_TOLERANCE_RAD = math.radians(0.5)
"""A finished moveL must end this close to its target; a UR arm repeats to +-0.03 mm."""
REACHED_TOLERANCE_Q_RAD = math.radians(0.1)
"""A finished moveJ must end with every joint this close to its target."""
STEADY_JOINT_SPEED_RPS = 0.002
"""The arm counts as steady (for latching a capture pose) when every joint is slower than this
(0.11 deg/s: under 2 mm/s at the reach of a UR10e) in two consecutive RTDE samples."""
MIN_SPEED_SCALING = 0.05
"""A move's timeout stretches with the speed slider, down to this fraction (20 times longer)."""
STOP_TIMEOUT_S = 5.0
"""stopL gets this long before the program is stopped through the dashboard instead. Waiting
does not leave the arm moving: while the ur_rtde process waits for the stopL answer it feeds no
watchdog, so the controller stops the program after ``watchdog_s`` anyway. (2 s was too short
for a simulated controller descheduled on a busy machine, which then answered late.)"""
STALE_LINK_S = 0.5
"""No new RTDE sample for this long during a move means the link is gone."""
OUTPUT_CONFIRM_TIMEOUT_S = 0.5
"""ur_rtde's IO setters return once the package is written; the controller must show the new
output value in its RTDE data within this time (250 cycles at 500 Hz)."""
TOOL_OUTPUT_FIRST_BIT = 16
"""Tool digital outputs (inputs) start at bit 16 of ``actual_digital_output_bits`` (``_input_``)."""


@dataclass(frozen=True)
class _MoveKind:
    """One async motion command as the child sends it: moveL (pose, m/s, m/s^2), moveJ
    (joints, rad/s, rad/s^2) or a moveL path (waypoint rows, see ``move_path``)."""

    name: str
    operation: str
    args: tuple[object, ...]  # the child operation's arguments
    description: str  # the target and its speeds, for the log and a refusal


def _single(
    name: str, operation: str, target: list[float], speed: float, accel: float
) -> _MoveKind:
    """A single moveL or moveJ to ``target`` at ``speed`` and ``accel``."""
    return _MoveKind(
        name, operation, (target, speed, accel), f"{_fmt_pose(target)} v={speed:.3f} a={accel:.3f}"
    )


def _fmt_pose(pose: list[float]) -> str:
    return "[" + ", ".join(f"{v:.4f}" for v in pose) + "]"


def _state_text(sample: Sample) -> str:
    return (
        f"safety mode {mode_name(SafetyMode, sample.safety_mode)}, runtime state "
        f"{mode_name(RuntimeState, sample.runtime_state)}, robot mode "
        f"{mode_name(RobotMode, sample.robot_mode)}"
    )


def _at_rest_on(sample: Sample, T_target: Transform) -> bool:
    """The TCP stands within the reached tolerance of ``T_target`` with every joint still."""
    T_now = ur_pose_to_matrix(sample.tcp_pose)
    off_m = float(np.linalg.norm(T_now[:3, 3] - T_target[:3, 3]))
    off_rad = rotation_angle_between(T_now[:3, :3], T_target[:3, :3])
    still = max(abs(v) for v in sample.qd) < STEADY_JOINT_SPEED_RPS
    return off_m <= REACHED_TOLERANCE_M and off_rad <= REACHED_TOLERANCE_RAD and still


def motion_fraction(T_start: Transform, T_now: Transform, T_target: Transform) -> float:
    """Fraction of a linear move done, 0..1, from the distance left (angle for pure rotations)."""
    total = float(np.linalg.norm(T_target[:3, 3] - T_start[:3, 3]))
    if total > 1e-3:
        left = float(np.linalg.norm(T_target[:3, 3] - T_now[:3, 3]))
    else:
        total = rotation_angle_between(T_start[:3, :3], T_target[:3, :3])
        left = rotation_angle_between(T_now[:3, :3], T_target[:3, :3])
        if total < 1e-6:
            return 1.0
    return min(1.0, max(0.0, 1.0 - left / total))


class URRtdeArm:
    """A connected UR arm through ur_rtde (implements ``RobotArm``); use as a context manager.

    ``with_io`` opens the RTDE IO interface, needed only for ``set_digital_output``.
    ``stop_decel_mps2`` is the stopL deceleration after a fault, a timeout or Ctrl-C.
    ``watchdog_s``: ur_rtde's controller-side watchdog stops the program when the ur_rtde
    process has been silent this long; it stays fed while this object's process lives.
    ``connect_timeout_s`` bounds the whole connection (ur_rtde can block forever on a controller
    that stops answering mid-handshake); ``call_timeout_s`` bounds every other call (ur_rtde
    itself gives up on a busy control script after about 4 s) and every dashboard connect and
    answer. ``on_sample`` hears every RTDE
    sample read (a recording's ``base -> flange``): every few ms while a move is watched.
    ``model`` (``robot.model``) is refused before ur_rtde connects when the dashboard names
    another arm.
    """

    def __init__(
        self,
        host: str,
        *,
        with_io: bool = False,
        stop_decel_mps2: float = 10.0,
        watchdog_s: float = 0.2,
        connect_timeout_s: float = 20.0,
        call_timeout_s: float = 6.0,
        on_sample: SampleListener | None = None,
        model: ArmModel | None = None,
    ) -> None:
        self.host = host
        self._on_sample = on_sample
        self._stop_decel_mps2 = stop_decel_mps2
        self._dashboard, self._version = connect_dashboard(host, call_timeout_s, model)
        self.controller_version = (
            "unknown" if self._version is None else ".".join(str(v) for v in self._version)
        )
        """PolyScope's version as the dashboard reports it ('5.15.0.1234')."""
        try:
            self._child = Child(
                host,
                with_io=with_io,
                watchdog_s=watchdog_s,
                connect_timeout_s=connect_timeout_s,
                call_timeout_s=call_timeout_s,
            )
        except BaseException:
            self._dashboard.close()
            raise
        try:
            self.tcp_offset()
        except BaseException:
            self.close()
            raise
        log.info("connected to %s: %s", host, self.controller_version)

    # --- context manager ---------------------------------------------------------------------

    def __enter__(self) -> URRtdeArm:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # --- RobotArm ----------------------------------------------------------------------------

    def status(self) -> RobotStatus:
        """Controller state from the latest RTDE sample plus the dashboard's remote-control flag."""
        sample = self._sample("sample")
        remote = self.remote_control()
        return RobotStatus(
            controller_version=self.controller_version,
            robot_mode=sample.robot_mode,
            safety_mode=sample.safety_mode,
            runtime_state=sample.runtime_state,
            remote_control=remote,
            protective_stopped=sample.protective_stopped,
            emergency_stopped=sample.emergency_stopped,
        )

    def tcp_offset(self) -> Transform:
        """``T_flange_tcp`` (m) asked from the controller now (``getTCPOffset``); later flange
        poses use this value, so the offset a pick checks is the offset its flange pose uses."""
        pose = self._child.call("tcp_offset")
        if not isinstance(pose, list) or len(pose) != 6:
            raise RobotFault(f"getTCPOffset on {self.host}: expected 6 numbers, got {pose!r}")
        T_flange_tcp = ur_pose_to_matrix(pose)
        self._T_flange_tcp: Transform = T_flange_tcp.copy()  # callers may modify what they get
        return T_flange_tcp

    def tcp_pose(self) -> Transform:
        """``T_base_tcp`` (m) from ``actual_TCP_pose`` of an RTDE sample newer than this call."""
        return ur_pose_to_matrix(self._sample("fresh_sample").tcp_pose)

    def flange_pose(self) -> Transform:
        """``T_base_flange`` (m) = fresh ``T_base_tcp`` @ inv(``T_flange_tcp``).

        ``T_flange_tcp`` is the offset last read by ``tcp_offset()`` (at connect, and by every
        pick before its flange pose); the pick verifies it against the config.
        """
        return self.tcp_pose() @ invert(self._T_flange_tcp)

    def is_pose_within_safety_limits(self, T_base_tcp: Transform) -> bool:
        return bool(self._child.call("is_pose_within_safety_limits", ur_pose_list(T_base_tcp)))

    def has_ik_solution(self, T_base_tcp: Transform) -> bool:
        return bool(self._child.call("has_ik_solution", ur_pose_list(T_base_tcp)))

    def move_linear(
        self,
        T_base_tcp: Transform,
        speed_mps: float,
        accel_mps2: float,
        timeout_s: float,
        on_progress: ProgressCallback | None = None,
    ) -> Transform:
        """Async moveL to ``T_base_tcp`` watched until done; returns the reached ``T_base_tcp``.

        Watched every ``POLL_PERIOD_S``: protective/emergency stop, safety mode, runtime state,
        robot mode, the link, and ``timeout_s``, counted in time at full speed (a speed slider
        at 50 % gives the move twice as long in wall-clock time). A fault sends stopL (where
        the link still works) and raises RobotFault; a lost link stops the program through a
        fresh dashboard connection and raises RobotConnectionError; Ctrl-C, or any other
        exception (a failing ``on_progress``), sends stopL and propagates. Remote control is the
        caller's check (``safety.ensure_remote_control``, before every move of a sequence).
        """

        def fraction(start: Sample, now: Sample) -> float:
            T_start, T_now = ur_pose_to_matrix(start.tcp_pose), ur_pose_to_matrix(now.tcp_pose)
            return motion_fraction(T_start, T_now, T_base_tcp)

        return self._move(
            _single("moveL", "move_l_async", ur_pose_list(T_base_tcp), speed_mps, accel_mps2),
            timeout_s,
            on_progress,
            fraction,
            lambda reached: self._check_reached(reached, T_base_tcp),
            lambda: self.stop_linear(self._stop_decel_mps2),
        )

    def move_path(
        self,
        waypoints: Sequence[Waypoint],
        timeout_s: float,
        on_progress: ProgressCallback | None = None,
    ) -> Transform:
        """One async moveL path (ur_rtde's ``moveL(path)``: each row ``[x, y, z, rx, ry, rz,
        speed, accel, blend]``) watched exactly as ``move_linear``; the last waypoint's radius
        is sent as 0 whatever it says, so the arm ends at rest on it. Progress: the controller
        reports the waypoint in progress (docs/ur-rtde.md, "Blended paths")."""
        if not waypoints:
            raise SafetyRefusal("a moveL path needs at least one waypoint, got none")
        rows = [
            [*ur_pose_list(w.T_base_tcp), w.speed_mps, w.accel_mps2, w.blend_m] for w in waypoints
        ]
        rows[-1][8] = 0.0
        targets = [w.T_base_tcp for w in waypoints]

        def fraction(start: Sample, now: Sample) -> float:
            index = min(max(now.async_progress, 0), len(targets) - 1)
            T_from = ur_pose_to_matrix(start.tcp_pose) if index == 0 else targets[index - 1]
            within = motion_fraction(T_from, ur_pose_to_matrix(now.tcp_pose), targets[index])
            return min(index + within, len(targets) - 1e-6) / len(targets)

        described = " -> ".join(
            f"{_fmt_pose(row[:6])} v={row[6]:.3f} a={row[7]:.3f} r={row[8] * 1000:.1f} mm"
            for row in rows
        )
        return self._move(
            _MoveKind("moveL path", "move_l_path_async", (rows,), described),
            timeout_s,
            on_progress,
            fraction,
            lambda reached: self._check_reached(reached, targets[-1]),
            lambda: self.stop_linear(self._stop_decel_mps2),
            # A path's program is uploaded afresh and counts its operations from zero again,
            # so after it the word may read exactly as before it (docs/ur-rtde.md).
            ended_unseen=lambda sample: _at_rest_on(sample, targets[-1]),
        )

    def move_joints(
        self,
        q_rad: Sequence[float],
        speed_rps: float,
        accel_rps2: float,
        timeout_s: float,
        on_progress: ProgressCallback | None = None,
    ) -> Transform:
        """Async moveJ to the joint positions ``q_rad`` (rad), watched exactly as ``move_linear``
        (stopJ instead of stopL); returns the reached ``T_base_tcp``."""
        target = [float(v) for v in q_rad]
        if len(target) != 6:
            raise SafetyRefusal(f"moveJ needs 6 joint positions (rad), got {len(target)}")

        def fraction(start: Sample, now: Sample) -> float:
            total = max(abs(t - s) for t, s in zip(target, start.q, strict=True))
            if total < 1e-6:
                return 1.0
            left = max(abs(t - v) for t, v in zip(target, now.q, strict=True))
            return min(1.0, max(0.0, 1.0 - left / total))

        return self._move(
            _single("moveJ", "move_j_async", target, speed_rps, accel_rps2),
            timeout_s,
            on_progress,
            fraction,
            lambda reached: self._check_reached_joints(reached, target),
            lambda: self.stop_joints(JOINT_STOP_DECEL_RPS2),
        )

    def steady_flange_pose(self, timeout_s: float) -> Transform:
        """``T_base_flange`` (m) latched from a fresh RTDE sample while the arm is steady: that
        sample and the fresh one before it show every joint slower than
        ``STEADY_JOINT_SPEED_RPS``. RobotFault when the arm is not at rest within ``timeout_s``.
        Uses the TCP offset last read by ``tcp_offset()``, as ``flange_pose``."""
        deadline = time.monotonic() + timeout_s
        steady_before = False
        while True:
            sample = self._sample("fresh_sample")
            fastest_rps = max(abs(v) for v in sample.qd)
            steady = fastest_rps <= STEADY_JOINT_SPEED_RPS
            if steady and steady_before:
                return ur_pose_to_matrix(sample.tcp_pose) @ invert(self._T_flange_tcp)
            steady_before = steady
            if time.monotonic() > deadline:
                raise self._fault(
                    f"the arm is not at rest after {timeout_s:g} s (fastest joint "
                    f"{fastest_rps:.4f} rad/s, steady means below {STEADY_JOINT_SPEED_RPS} rad/s)",
                    sample,
                )

    def joint_positions(self) -> tuple[float, ...]:
        """``actual_q`` (rad) of the latest RTDE sample."""
        return tuple(self._sample("sample").q)

    def joints_within_safety_limits(self, q_rad: Sequence[float]) -> bool:
        return bool(self._child.call("is_joints_within_safety_limits", [float(v) for v in q_rad]))

    def _move(
        self,
        kind: _MoveKind,
        timeout_s: float,
        on_progress: ProgressCallback | None,
        fraction: Callable[[Sample, Sample], float],
        check_reached: Callable[[Sample], None],
        stop: Callable[[], None],
        ended_unseen: Callable[[Sample], bool] | None = None,
    ) -> Transform:
        """Send one async move and watch it to its end (see ``move_linear``; ``ended_unseen``
        as ``_watch_motion``)."""
        start = self._sample("fresh_sample")
        try:
            self._check_motion_sample(start, kind.name)  # never start on a broken link or stop
            log.debug("%s %s", kind.name, kind.description)
            if not self._child.call(kind.operation, *kind.args):
                after = self._sample("sample")
                raise self._fault(f"{kind.name} to {kind.description} was refused", after)
            self._watch_motion(kind.name, start, timeout_s, on_progress, fraction, ended_unseen)
            reached = self._sample("fresh_sample")
            self._check_motion_sample(reached, kind.name)
            check_reached(reached)
        except RobotConnectionError:
            self._stop_by_dashboard()
            raise
        except BaseException as exc:  # a fault, Ctrl-C, or anything unforeseen: never keep moving
            log.warning("%s ended by %s: stopping the arm", kind.name, type(exc).__name__)
            stop()
            raise
        return ur_pose_to_matrix(reached.tcp_pose)

    def stop_linear(self, decel_mps2: float) -> None:
        """stopL; best effort: on a dead link it stops the program through the dashboard."""
        self._stop("stop_l", decel_mps2)

    def stop_joints(self, decel_rps2: float) -> None:
        """stopJ; best effort like ``stop_linear``."""
        self._stop("stop_j", decel_rps2)

    def _stop(self, operation: str, decel: float) -> None:
        if self._child.dead_reason is not None:
            self._stop_by_dashboard()
            return
        try:
            self._child.call(operation, decel, timeout_s=STOP_TIMEOUT_S)
        except RobotError as exc:
            log.warning("%s on %s failed (%s)", operation, self.host, exc)
            if isinstance(exc, RobotConnectionError):
                self._stop_by_dashboard()

    def set_digital_output(self, bank: OutputBank, index: int, value: bool) -> None:
        """Set one output and wait until the controller's RTDE data shows it (the setter itself
        only says the request was written); RobotFault when it does not within
        ``OUTPUT_CONFIRM_TIMEOUT_S``, RobotConnectionError when no fresh data comes."""
        what = f"set {bank.value} digital output {index} to {value}"
        if bank is OutputBank.STANDARD:
            operation, bit = "set_standard_digital_out", index
        else:
            operation, bit = "set_tool_digital_out", TOOL_OUTPUT_FIRST_BIT + index
        if not self._child.call(operation, index, value):
            raise self._fault(f"{what} was refused", self._sample("sample"))
        deadline = time.monotonic() + OUTPUT_CONFIRM_TIMEOUT_S
        while True:
            sample = self._sample("fresh_sample")
            if bool(sample.digital_output_bits >> bit & 1) == value:
                return
            if time.monotonic() > deadline:
                raise self._fault(
                    f"{what}: the controller still shows {not value} after "
                    f"{OUTPUT_CONFIRM_TIMEOUT_S} s",
                    sample,
                )

    def digital_input(self, bank: OutputBank, index: int) -> bool:
        """One digital input from the latest RTDE sample (``actual_digital_input_bits``)."""
        bit = TOOL_OUTPUT_FIRST_BIT + index if bank is OutputBank.TOOL else index
        return bool(self._sample("sample").digital_input_bits >> bit & 1)

    def set_payload(self, mass_kg: float, cog_flange_m: Sequence[float]) -> None:
        """``setPayload(mass, cog)`` (kg, m in the flange frame); RobotFault when refused."""
        cog = [float(v) for v in cog_flange_m]
        if not self._child.call("set_payload", float(mass_kg), cog):
            raise self._fault(
                f"setPayload({mass_kg:g} kg, CoG {_fmt_pose(cog)} m) was refused",
                self._sample("sample"),
            )

    def close(self) -> None:
        """Disconnect every interface, end the child and close the dashboard connection; safe to
        call twice."""
        self._child.close()
        self._dashboard.close()

    def remote_control(self) -> bool:
        """The pendant's Remote Control mode, asked on the session's dashboard connection; True
        without asking on a controller that has no such mode (robot/ur/dashboard.py).

        A dashboard that no longer answers ends the session: the arm is stopped (stopL, then the
        starved watchdog stops the program) and ``RobotConnectionError`` says so in one line."""
        self._child.require_alive("remote control")
        try:
            return self._dashboard.in_remote_control(self._version)
        except OSError as exc:
            error = dashboard_lost_error(self.host, "remote control", exc)
        self.stop_linear(self._stop_decel_mps2)
        self._child.end(str(error))
        self._dashboard.close()
        raise error

    # --- motion watch ------------------------------------------------------------------------

    def _watch_motion(
        self,
        name: str,
        start: Sample,
        timeout_s: float,
        on_progress: ProgressCallback | None,
        fraction: Callable[[Sample, Sample], float],
        ended_unseen: Callable[[Sample], bool] | None = None,
    ) -> None:
        """Poll until the async operation the move started has ended. Ended: not running, and
        either its operation id differs from the one before the move or it was seen running;
        when neither (the operation id can repeat) ``ended_unseen`` decides from the sample."""
        motion_time_s = 0.0
        seen_running = False  # time at full speed: runs slower while the speed slider is down
        last_timestamp = start.timestamp_s
        last_new_sample = last_now = time.monotonic()
        while True:
            sample = self._sample("sample")
            now = time.monotonic()
            motion_time_s += (now - last_now) * max(sample.speed_scaling, MIN_SPEED_SCALING)
            last_now = now
            self._check_motion_sample(sample, name)
            if sample.timestamp_s != last_timestamp:
                last_timestamp, last_new_sample = sample.timestamp_s, now
            elif now - last_new_sample > STALE_LINK_S:
                raise self._link_lost(name, f"no RTDE data for {STALE_LINK_S} s during {name}")
            # The operation id changes when the move starts, so a move that ended before this
            # first look still reads as done.
            seen_running = seen_running or sample.async_running
            done = not sample.async_running and (
                seen_running
                or sample.async_operation_id != start.async_operation_id
                or (ended_unseen is not None and ended_unseen(sample))
            )
            if on_progress is not None:
                on_progress(1.0 if done else fraction(start, sample))
            if done:
                return
            if motion_time_s > timeout_s:
                raise self._fault(
                    f"{name} did not finish within {timeout_s:.1f} s (at full speed)", sample
                )
            time.sleep(POLL_PERIOD_S)

    def _check_motion_sample(self, sample: Sample, name: str = "moveL") -> None:
        if not (sample.receive_connected and sample.control_connected):
            raise self._link_lost(name, "the RTDE connection dropped")
        if sample.protective_stopped or sample.emergency_stopped:
            kind = "protective stop" if sample.protective_stopped else "emergency stop"
            raise self._fault(f"{name}: {kind} active", sample)
        if sample.safety_mode not in (SafetyMode.NORMAL, SafetyMode.REDUCED):
            raise self._fault(f"{name}: the controller is not in normal safety mode", sample)
        if sample.runtime_state != RuntimeState.PLAYING:
            raise self._fault(f"{name}: the control program is not running", sample)
        if sample.robot_mode != RobotMode.RUNNING:
            raise self._fault(f"{name}: the arm is not running", sample)

    def _check_reached(self, sample: Sample, T_target: Transform) -> None:
        """The async move reported its end: make sure it ended at the target, not short of it
        (a program stopped mid-move also ends the async operation)."""
        T_reached = ur_pose_to_matrix(sample.tcp_pose)
        off_m = float(np.linalg.norm(T_reached[:3, 3] - T_target[:3, 3]))
        off_rad = rotation_angle_between(T_reached[:3, :3], T_target[:3, :3])
        if off_m > REACHED_TOLERANCE_M or off_rad > REACHED_TOLERANCE_RAD:
            raise self._fault(
                f"moveL ended {off_m * 1000:.1f} mm and {math.degrees(off_rad):.2f} deg away "
                f"from its target (tolerance {REACHED_TOLERANCE_M * 1000:g} mm, "
                f"{math.degrees(REACHED_TOLERANCE_RAD):g} deg)",
                sample,
            )

    def _check_reached_joints(self, sample: Sample, q_target: list[float]) -> None:
        """As ``_check_reached``, for a moveJ: every joint within ``REACHED_TOLERANCE_Q_RAD``."""
        off_rad = max(abs(t - v) for t, v in zip(q_target, sample.q, strict=True))
        if off_rad > REACHED_TOLERANCE_Q_RAD:
            raise self._fault(
                f"moveJ ended {math.degrees(off_rad):.2f} deg from its target on some joint "
                f"(tolerance {math.degrees(REACHED_TOLERANCE_Q_RAD):g} deg)",
                sample,
            )

    def _fault(self, what: str, sample: Sample) -> RobotFault:
        return RobotFault(
            f"{what} on {self.host} ({_state_text(sample)})",
            safety_mode=sample.safety_mode,
            runtime_state=sample.runtime_state,
            robot_mode=sample.robot_mode,
        )

    def _link_lost(self, name: str, reason: str) -> RobotConnectionError:
        """End the session for ``reason``; the error that says so."""
        self._child.end(reason)
        return RobotConnectionError(f"{name} on {self.host}: {reason}")

    def _stop_by_dashboard(self) -> None:
        """End the child (it may be reconnecting), then stop the program through fresh
        dashboard connections until the controller confirms (robot/ur/dashboard.py)."""
        self._child.end()
        stop_program_until_confirmed(self.host)

    def _sample(self, operation: str) -> Sample:
        fields = self._child.call(operation)
        if not isinstance(fields, dict):
            raise RobotConnectionError(f"{operation} on {self.host}: unexpected reply {fields!r}")
        sample = Sample(**fields)
        if self._on_sample is not None:
            self._on_sample(sample.tcp_pose, sample.timestamp_s)
        return sample
