"""Running a checked sequence of steps: the moves, the gripper, the payload and the watch over a
carried part. ``session.Cell`` runs a sequence only after it passed every check and its plan is
on disk; nothing here opens a file or a connection.

Frames and units: move targets are ``T_base_tcp`` float64 4x4 in metres, joint targets radians,
speeds m/s (rad/s for joints), times seconds. Every command's speed is capped again right before
it is sent (``safety``), whatever the config said.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from handeye_pick.cell.blend import BLEND_SHARE, MIN_BLEND_M
from handeye_pick.cell.motion_time import trapezoid_s
from handeye_pick.cell.payload import held_payload
from handeye_pick.cell.plan import RETREAT
from handeye_pick.config.schema import CellConfig, Payload
from handeye_pick.errors import (
    HandEyePickError,
    InputError,
    PartDropped,
    RobotError,
    SafetyRefusal,
    SequenceAborted,
    StopRequested,
)
from handeye_pick.geometry import Transform, rotation_angle_between, ur_pose_list
from handeye_pick.gripper.port import GraspState, Gripper
from handeye_pick.limits import MAX_GRASP_SPEED_MPS, MAX_SPEED_MPS
from handeye_pick.progress import Progress
from handeye_pick.robot.port import ProgressCallback, RobotArm, Waypoint
from handeye_pick.safety import check_joint_command, check_motion_command, ensure_remote_control
from handeye_pick.steps import Grip, JointMove, Move, Step

TIMEOUT_FACTOR = 1.5
"""A move may take this much longer than its trapezoid profile (speed slider, controller
ramps) before the margin from the config starts counting."""

GRASP_WATCH_PERIOD_S = 0.05
"""How often a carried part is looked at during a move (each look is a gripper round trip)."""


def move_timeout_s(
    T_from: Transform, T_to: Transform, speed_mps: float, accel_mps2: float, margin_s: float
) -> float:
    """Upper bound for a moveL: its trapezoid time times ``TIMEOUT_FACTOR`` plus ``margin_s``.

    The path length is the larger of the translation (m) and the rotation (rad, as if turning at
    ``speed_mps`` rad/s), so a move that mostly turns the tool still gets enough time.
    """
    distance = max(
        float(np.linalg.norm(T_to[:3, 3] - T_from[:3, 3])),
        rotation_angle_between(T_from[:3, :3], T_to[:3, :3]),
    )
    return trapezoid_s(distance, speed_mps, accel_mps2) * TIMEOUT_FACTOR + margin_s


def joint_move_timeout_s(
    q_from: Sequence[float],
    q_to: Sequence[float],
    speed_rps: float,
    accel_rps2: float,
    margin_s: float,
) -> float:
    """Upper bound for a moveJ, as ``move_timeout_s`` over the largest joint travel (rad)."""
    distance = max(abs(b - a) for a, b in zip(q_from, q_to, strict=True))
    return trapezoid_s(distance, speed_rps, accel_rps2) * TIMEOUT_FACTOR + margin_s


@dataclass(frozen=True)
class Executed:
    """What ``execute`` did: the reached ``T_base_tcp`` per move name, and the grasp as the
    gripper sensed it when it closed (None: no gripper closed)."""

    reached: dict[str, Transform]
    grasp: GraspState | None = None
    missed: str | None = None  # why the gripper sensed no part (``Gripper.why_missed``)


def execute(
    config: CellConfig,
    steps: Sequence[Step],
    arm: RobotArm,
    progress: Progress,
    outcome: dict[str, object],
    before_move: Callable[[str], None] | None = None,
    gripper: Gripper | None = None,
    holding: GraspState | None = None,
    watch: SequenceWatch | None = None,
) -> Executed:
    """Run ``steps`` in order.

    ``outcome["step"]`` names the step running (kept when one fails, removed at the end) and
    ``outcome["reached"]`` fills as moves end, so the audit says how far a sequence got;
    ``outcome["gripper"]`` lists the gripper's commands, their sensed states and the payloads
    set. ``before_move`` is called with a move's name right before it is sent (an operator's
    confirmation). Every command's speed is capped again here, whatever the config said.

    The gripper: a missed grasp opens the gripper, runs the retreat and ends the sequence there
    (``Executed.grasp`` says so). A held part (confirmed or unconfirmed) gets the object payload
    before the next move, the empty tool's after its release. While a confirmed part is carried,
    every move watches it; a lost part raises ``PartDropped`` (the adapter stops the arm).
    ``holding`` is the grasp of a part already held when the sequence starts (a pick that did
    not place it), watched the same way.

    ``watch`` (``SequenceWatch``) hears of every step as it starts, a path's waypoints
    included, and may ask the sequence to stop: before each step, and at every look while the
    arm moves, a set ``watch.stop`` raises ``StopRequested`` (the adapter sends stopL).
    """
    run = _Run(config, arm, progress, outcome, gripper, holding, watch or SequenceWatch())
    index = 0
    while index < len(steps):
        step = steps[index]
        run.starting(step.name)
        # Each move confirmed on its own (before_move) runs on its own: no blends.
        path = path_at(steps, index, run.last_move) if before_move is None else []
        try:
            if isinstance(step, Grip):
                run.grip(step)
            elif len(path) > 1:
                run.path(path)
            else:
                if before_move is not None:
                    before_move(step.name)
                run.move(step)
        except (SafetyRefusal, InputError) as exc:
            if not run.reached:  # nothing has moved yet: a refusal, as before the sequence
                raise
            raise run.aborted(step.name, exc) from exc
        ran = [step.name] if len(path) <= 1 else [move.name for move in path]
        index += len(ran)
        if run.last_move in ran:
            break
    del outcome["step"]
    return Executed(run.reached, run.grasp, run.missed)


@dataclass(frozen=True)
class SequenceWatch:
    """Who watches a running sequence from outside: ``on_step`` hears each step's name as it
    starts, ``on_reached`` each stop's name, target (None for a moveJ) and reached
    ``T_base_tcp`` (m), ``on_look`` the step in progress at every look while the arm moves
    (it must not raise: an exception from it stops the arm); ``stop``, once set (from any
    thread), brakes the arm at the next look."""

    on_step: Callable[[str], None] | None = None
    on_reached: Callable[[str, Transform | None, Transform], None] | None = None
    on_look: Callable[[str], None] | None = None
    stop: threading.Event = field(default_factory=threading.Event)


class _Run:
    """The state of one ``execute``: what was reached, what the gripper holds, where the TCP
    starts its next move from."""

    def __init__(
        self,
        config: CellConfig,
        arm: RobotArm,
        progress: Progress,
        outcome: dict[str, object],
        gripper: Gripper | None,
        holding: GraspState | None,
        watch: SequenceWatch,
    ) -> None:
        self.watch = watch
        self.config = config
        self.outcome = outcome
        self.arm = arm
        self.progress = progress
        self.gripper = gripper
        self.grasp = holding
        self.reached: dict[str, Transform] = {}
        self.reached_ur: dict[str, list[float]] = {}
        outcome["reached"] = self.reached_ur
        self.commands: list[dict[str, object]] = []
        if gripper is not None:
            outcome["gripper"] = {"kind": gripper.kind, "commands": self.commands}
        self.last_move: str | None = None  # a missed grasp ends the sequence after this move
        self.missed: str | None = None  # why the grasp missed
        self.T_base_tcp_from: Transform | None = None  # the previous move's target

    def starting(self, step: str) -> None:
        """``step`` is the one in progress now (the outcome says so); a stop request ends the
        sequence before it starts."""
        self._announce(step)
        self._stop_if_asked(step, None)

    def _announce(self, step: str) -> None:
        if self.outcome.get("step") != step:
            self.outcome["step"] = step
            if self.watch.on_step is not None:
                self.watch.on_step(step)

    def _stop_if_asked(self, step: str, fraction: float | None) -> None:
        if not self.watch.stop.is_set():
            return
        where = "before it started" if fraction is None else f"at {fraction:.0%} of the move"
        raise StopRequested(
            f"{step}: stopped by request {where}; the cell is halted: resume when ready"
        )

    def aborted(self, step: str, exc: HandEyePickError) -> SequenceAborted:
        """A refusal once the arm has moved: stop it where it stands (it is at rest after its
        last move; the stop makes sure) and end the sequence as a fault."""
        last = list(self.reached)[-1]
        try:
            self.arm.stop_linear(self.config.motion.stop_decel_mps2)
            self.outcome["stop"] = "stopL sent"
        except RobotError as stop_error:  # the refusal is what the operator must see first
            self.outcome["stop"] = f"stopL failed: {stop_error}"
        return SequenceAborted(
            f"{step} refused after the arm had moved, so it stands at {last!r}, not where the "
            f"sequence started: {exc}; the cell is halted: clear the cause, then resume"
        )

    def grip(self, step: Grip) -> None:
        """Close (and confirm) or open the gripper; set the payload that follows."""
        gripper, progress, commands = self.gripper, self.progress, self.commands
        if gripper is None:
            return
        if not step.close:
            _release(gripper, progress, commands)
            self.grasp = None
            _set_payload(self.arm, self.config.robot.tool_payload, "empty tool", progress, commands)
            return
        self.grasp, self.missed = _close(gripper, progress, commands)
        if self.grasp is GraspState.MISSED:
            _release(gripper, progress, commands)
            _set_payload(self.arm, self.config.robot.tool_payload, "empty tool", progress, commands)
            self.last_move = RETREAT
        else:
            _set_payload(self.arm, _object_payload(self.config), "part", progress, commands)

    def _tool_payload_after_loss(self) -> None:
        """The empty tool's payload after a dropped part (a wrong payload shows up as protective
        stops); the arm is stopped already, so a controller that refuses it now is recorded,
        not raised over the drop."""
        tool = self.config.robot.tool_payload
        try:
            _set_payload(self.arm, tool, "empty tool", self.progress, self.commands)
        except RobotError as exc:
            self.commands.append(
                {"command": "set_payload", "payload": "empty tool", "error": str(exc)}
            )

    def move(self, step: Move | JointMove) -> None:
        """One moveJ or moveL, its command capped and its timeout bounded before it is sent; a
        confirmed part is watched while it runs."""
        command = "moveJ" if isinstance(step, JointMove) else "moveL"
        ensure_remote_control(self.arm.remote_control(), self.config.robot.host, command)
        send = self._joint_command(step) if isinstance(step, JointMove) else self._linear(step)
        reached = self._drive(step.name, send)
        target = None if isinstance(step, JointMove) else step.T_base_tcp
        self.T_base_tcp_from = reached if target is None else target
        self._reached(step.name, target, reached)

    def path(self, moves: Sequence[Move]) -> None:
        """Consecutive moveL targets as one blended path (``path_at``), every waypoint's speed
        capped and the whole path's timeout bounded before it is sent; ``outcome["step"]``
        follows the waypoint in progress. Only the last target is a stop, so only its pose is
        recorded as reached."""
        motion = self.config.motion
        ensure_remote_control(self.arm.remote_control(), self.config.robot.host, "moveL path")
        T_from = self.T_base_tcp_from if self.T_base_tcp_from is not None else self.arm.tcp_pose()
        waypoints, timeout_s = [], motion.timeout_margin_s
        for move in moves:
            speed_mps = self._speed_mps(move)
            timeout_s += move_timeout_s(T_from, move.T_base_tcp, speed_mps, motion.accel_mps2, 0.0)
            waypoints.append(Waypoint(move.T_base_tcp, speed_mps, motion.accel_mps2, move.blend_m))
            T_from = move.T_base_tcp
        waypoints[0] = self._first_corner(waypoints[0])
        names = [move.name for move in moves]

        def follow(watch: ProgressCallback) -> ProgressCallback:
            def on_progress(fraction: float) -> None:
                # The path is moving: ``watch`` brakes it on a stop request, at this fraction.
                self._announce(names[min(int(fraction * len(names)), len(names) - 1)])
                watch(fraction)

            return on_progress

        reached = self._drive(
            " -> ".join(names),
            lambda watch: self.arm.move_path(waypoints, timeout_s, follow(watch)),
        )
        self.T_base_tcp_from = moves[-1].T_base_tcp
        self._reached(names[-1], moves[-1].T_base_tcp, reached)

    def _first_corner(self, first: Waypoint) -> Waypoint:
        """The first corner's radius was planned from where the arm stood then; it never takes
        more than ``BLEND_SHARE`` of the segment from where the arm stands now."""
        if first.blend_m == 0.0:
            return first
        here = self.arm.tcp_pose()[:3, 3]
        room = BLEND_SHARE * float(np.linalg.norm(first.T_base_tcp[:3, 3] - here))
        return replace(first, blend_m=min(first.blend_m, room) if room >= MIN_BLEND_M else 0.0)

    def _drive(self, name: str, send: Callable[[ProgressCallback], Transform]) -> Transform:
        """Send one motion command; at every look, brake on a stop request and, while a
        confirmed part is carried, watch it."""
        watched = self.gripper if self.grasp is GraspState.CONFIRMED else None

        def stoppable(report: ProgressCallback) -> ProgressCallback:
            def on_progress(fraction: float) -> None:
                self._stop_if_asked(name, fraction)
                report(fraction)
                if self.watch.on_look is not None:
                    self.watch.on_look(str(self.outcome.get("step", name)))

            return on_progress

        try:
            with self.progress.step(name) as report:
                return send(_watching(stoppable(report), watched, name))
        except PartDropped:
            self.grasp = None  # the part is gone: the tool alone hangs on the flange again
            self._tool_payload_after_loss()
            raise

    def _reached(self, name: str, target: Transform | None, reached: Transform) -> None:
        self.reached[name] = reached
        self.reached_ur[name] = ur_pose_list(reached)
        if self.watch.on_reached is not None:
            self.watch.on_reached(name, target, reached)

    def _joint_command(self, step: JointMove) -> Callable[[ProgressCallback], Transform]:
        motion = self.config.motion
        check_joint_command(motion.joint_speed_rps)
        timeout_s = joint_move_timeout_s(
            self.arm.joint_positions(),
            step.q_rad,
            motion.joint_speed_rps,
            motion.joint_accel_rps2,
            motion.timeout_margin_s,
        )
        return lambda watch: self.arm.move_joints(
            step.q_rad, motion.joint_speed_rps, motion.joint_accel_rps2, timeout_s, watch
        )

    def _speed_mps(self, step: Move) -> float:
        """The speed of a moveL, checked against its own cap (the grasp speed's for a descent)."""
        motion = self.config.motion
        speed_mps, cap_mps = (
            (motion.grasp_speed_mps, MAX_GRASP_SPEED_MPS)
            if step.slow
            else (motion.speed_mps, MAX_SPEED_MPS)
        )
        check_motion_command(speed_mps, motion.accel_mps2, max_speed_mps=cap_mps)
        return speed_mps

    def _linear(self, step: Move) -> Callable[[ProgressCallback], Transform]:
        motion = self.config.motion
        speed_mps = self._speed_mps(step)
        T_from = self.T_base_tcp_from if self.T_base_tcp_from is not None else self.arm.tcp_pose()
        timeout_s = move_timeout_s(
            T_from, step.T_base_tcp, speed_mps, motion.accel_mps2, motion.timeout_margin_s
        )
        return lambda watch: self.arm.move_linear(
            step.T_base_tcp, speed_mps, motion.accel_mps2, timeout_s, watch
        )


def path_at(steps: Sequence[Step], index: int, last_move: str | None) -> list[Move]:
    """The moveL targets driven together from ``steps[index]`` (none when it is no moveL):
    while a target is blended (``blend_m`` > 0) the next moveL joins it; a gripper action, a
    moveJ, a stop or ``last_move`` (a missed grasp's retreat) ends the path."""
    path: list[Move] = []
    while index + len(path) < len(steps):
        step = steps[index + len(path)]
        if not isinstance(step, Move):
            break
        path.append(step)
        if step.blend_m == 0.0 or step.name == last_move:
            break
    return path


def _close(
    gripper: Gripper, progress: Progress, commands: list[dict[str, object]]
) -> tuple[GraspState, str | None]:
    """Close the gripper; the grasp it senses and, when it missed, why (for the audit's command
    record, the progress line and the reply)."""
    with progress.step(f"gripper close ({gripper.kind})"):
        grasp = gripper.close()
    why = gripper.why_missed() if grasp is GraspState.MISSED else None
    commands.append({"command": "close", "grasp": grasp.value, **({"why": why} if why else {})})
    progress.say(f"grasp {grasp.value}" + (f": {why}" if why else ""))
    return grasp, why
    return grasp


def _release(gripper: Gripper, progress: Progress, commands: list[dict[str, object]]) -> None:
    with progress.step(f"gripper open ({gripper.kind})"):
        sensed = gripper.open()
    commands.append({"command": "open", "release": "confirmed" if sensed else "unconfirmed"})


def _object_payload(config: CellConfig) -> Payload | None:
    """The tool holding the configured part (None: no part configured, payload left alone)."""
    tool, part = config.robot.tool_payload, config.object
    if tool is None or part is None:  # the config loader requires the tool's with the part's
        return None
    return held_payload(tool, part, config.robot.T_flange_tcp)


def _set_payload(
    arm: RobotArm,
    payload: Payload | None,
    what: str,
    progress: Progress,
    commands: list[dict[str, object]],
) -> None:
    if payload is None:
        return
    with progress.step(f"payload {payload.mass_kg:g} kg ({what})"):
        arm.set_payload(payload.mass_kg, payload.cog_flange_m)
    commands.append(
        {
            "command": "set_payload",
            "payload": what,
            "mass_kg": payload.mass_kg,
            "cog_flange_m": list(payload.cog_flange_m),
        }
    )


def _watching(report: ProgressCallback, gripper: Gripper | None, move: str) -> ProgressCallback:
    """``report``, and while ``gripper`` holds a confirmed part, a look at it every
    ``GRASP_WATCH_PERIOD_S`` and when the move ends: a lost part raises ``PartDropped`` (the
    adapter stops the arm for any exception from its progress callback)."""
    if gripper is None:
        return report
    last_look = -math.inf

    def watch(fraction: float) -> None:
        nonlocal last_look
        report(fraction)
        now = time.monotonic()
        if fraction < 1.0 and now - last_look < GRASP_WATCH_PERIOD_S:
            return
        last_look = now
        if gripper.state() is not GraspState.CONFIRMED:
            raise PartDropped(
                f"{move}: the {gripper.kind} gripper lost the part at {fraction:.0%} of the "
                "move: the arm was stopped; clear the part, then resume"
            )

    return watch
