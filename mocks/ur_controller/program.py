"""Emulation of ur_rtde's control script (rtde_control.script), one control cycle at a time.

Register protocol (docs/ur-rtde.md, "Register protocol"): the client writes a command id to
input_int_register_0 (+offset) and arguments to the other input registers; the script answers on
output_int_register_0: 1 = ready, 2 = done with the command. Per cycle ("The script's loop"):

- realtime ids are processed every cycle while they stay in the register, then 1 is written;
- 0 clears the `executing` latch and writes 1;
- any other id is processed once (edge-triggered, a new id is ignored until a 0 was seen); a
  synchronous motion blocks the script until it ends, then 2 is written;
- 255 ends the program without writing 2.

Output registers written in a cycle reach clients with the next RTDE sample.
A command this emulator does not implement stops the program, as a URScript runtime error would,
and is logged loudly: the client sees `runtime_state` leave PLAYING and returns False instead of
waiting 300 s for an answer that never comes.

Command 45 (MOVE_PATH) runs the path ur_rtde injected into the uploaded script (path_script.py)
as one motion, in the move thread when async. The path is planned off the control thread
(path_plan.py): the command waits, as a synchronous move does, until its plan is ready, and the
path starts at the first cycle after that; the script writes the progress word with
the index of each waypoint as the arm starts heading for it (signal_async_progress(i)), and only
the async thread writes "finished" at the end: after a synchronous path the word still reads
running with the last index, as on a real controller.

Fault refuse-move: the next motion command is not run and never answered; while its id stays in
the register (`refusing`) the controller reports runtime_state PAUSING (3) instead of PLAYING.
That is the only way ur_rtde 1.6.5's sendCommand returns False at once without a protective stop,
an emergency stop or a stopped program (it polls runtime_state while it waits for the answer);
ur_rtde then clears the register and everything reads normal again.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from mocks.ur_controller import kinematics as kin
from mocks.ur_controller.arm import Arm, Motion, UnreachableError, Vector
from mocks.ur_controller.path_plan import PathPlanner, PlanRequest
from mocks.ur_controller.path_script import PathSpec
from mocks.ur_controller.record import CommandRecord

log = logging.getLogger("mocks.ur_controller")

READY = 1
DONE = 2
STOP_SCRIPT = 255
# Processed every cycle while present (the script's realtime branch plus 1.6.5's additions).
REALTIME_IDS = frozenset({6, 9, 10, 11, 24, 25, 26, 27, 38, 58, 66, 67, 68, 69, 70, 71})
MOTION_KINDS = {1: "moveJ", 2: "moveJ_IK", 3: "moveL", 4: "moveL_FK"}
MOVE_PATH = 45
PAYLOAD_KINDS = {17: "setPayload", 65: "setTargetPayload"}


class Registers:
    """The controller's RTDE general-purpose registers (48 of each kind)."""

    def __init__(self) -> None:
        self.in_int = [0] * 48
        self.in_double = [0.0] * 48
        self.out_int = [0] * 48
        self.out_double = [0.0] * 48
        self.in_bits = [False] * 128
        self.out_bits = [False] * 128
        # Controller time of the cycle that took in the last client write to each input int
        # register (the watchdog's "update"), and the registers written since the last cycle,
        # each with the controller time by the wall clock when the write arrived.
        self.in_int_written_s = [0.0] * 48
        self.in_int_fresh: dict[int, float] = {}
        # Writes taken in per input int register: whether a value came before or after a
        # moment, which the stamps above cannot say while a late loop catches up.
        self.in_int_writes = [0] * 48

    def take_in_writes(self, now_s: float) -> None:
        """Start of a cycle: inputs written since the last one count as updated now, or when
        they arrived if that is later (a late loop catching up runs cycles stamped before it)."""
        for n, arrived_s in self.in_int_fresh.items():
            self.in_int_written_s[n] = max(now_s, arrived_s)
            self.in_int_writes[n] += 1
        self.in_int_fresh.clear()


class ControlScript:
    """The running `rtde_control` program: call `cycle()` once per control cycle."""

    name = "rtde_control"  # what the dashboard's programState names it: the script's def

    def __init__(self, registers: Registers, arm: Arm, record: CommandRecord, reg_offset: int,
                 protective_stop: Callable[[str], None], take_refused_move: Callable[[], bool],
                 now_s: float, planner: PathPlanner, path: PathSpec | None = None,
                 plan: PlanRequest | None = None):
        self._reg = registers
        self._writes_at_start = registers.in_int_writes[reg_offset]
        self._path = path  # injected at `# inject move path`, run by command 45
        self._planner = planner
        self._plan = plan  # the path's plan, asked for when the program arrived
        self._path_command: tuple[PlanRequest, dict[str, Any]] | None = None  # 45, planning
        self._arm = arm
        self._commands = record
        self._off = reg_offset
        self._protective_stop = protective_stop
        self._take_refused_move = take_refused_move  # fault refuse-move, one move per call
        self.running = True
        self.ack_delay_s = 0.0  # fault slow:SECONDS: extra time before each DONE
        self.refusing = False  # a refused motion command is still in the register
        self._executing = False
        self._blocked_until_s: float | None = None  # a synchronous command is still running
        self._blocking_motion: Motion | None = None
        self._async_motion: Motion | None = None
        self._path_motion: Motion | None = None
        self._path_progress = 0  # the last waypoint index signalled
        self._async_write_count = 0
        self._async_op_id = 0
        self._watchdog_hz: float | None = None
        self._now_s = now_s
        self._write_async_word(-1)  # reset_async_progress(): "finished"
        self._set_out_int(0, READY)

    # --- register access (offset applied) ---------------------------------------------------

    def _in_int(self, n: int) -> int:
        return self._reg.in_int[self._off + n]

    def _in_doubles(self, first: int, count: int = 6) -> Vector:
        return np.array(self._reg.in_double[self._off + first : self._off + first + count])

    def _set_out_int(self, n: int, value: int) -> None:
        self._reg.out_int[self._off + n] = value

    def _set_out_doubles(self, values: Vector) -> None:
        for i, value in enumerate(values):
            self._reg.out_double[self._off + i] = float(value)

    def _write_async_word(self, progress: int) -> None:
        """The async progress word (docs/ur-rtde.md, "Async progress word"): >= 0 is running."""
        self._async_write_count = (self._async_write_count + 1) % 128
        if progress == 0:
            self._async_op_id = (self._async_op_id + 1) % 128
        word = self._async_write_count * 65536 + self._async_op_id * 16777216
        if progress >= 0:
            word += min(progress, 32767) + 32768
        self._set_out_int(2, word)

    # --- the main loop, one cycle -----------------------------------------------------------

    def cycle(self, now_s: float) -> None:
        """One pass of the script's main loop (the `sync()` at its end is the cycle boundary)."""
        self._now_s = now_s
        if not self.running:
            return
        if self._watchdog_starved(now_s):
            return
        self._signal_path_progress()
        if self._async_motion is not None and self._arm.motion is not self._async_motion:
            self._async_motion = None  # the move thread ran to its end or was stopped
            self._write_async_word(-1)
        if self._blocked_until_s is not None:
            if self._path_command is not None:
                self._start_planned_path()
            if self.running:
                self._finish_command(now_s, self._blocked_until_s)
            return
        cmd = self._in_int(0)
        if cmd == STOP_SCRIPT and self._reg.in_int_writes[self._off] == self._writes_at_start:
            # The 255 that stopped the previous program: ur_rtde clears it before it uploads
            # this one, and on a controller the clear always lands while the upload compiles.
            return
        if cmd in REALTIME_IDS:
            self._process(cmd)
            if self.running:
                self._set_out_int(0, READY)
        elif cmd == 0:
            self._executing = False
            self.refusing = False
            self._set_out_int(0, READY)
        elif not self._executing:
            self._executing = True
            self._process(cmd)
            if self.running and cmd != STOP_SCRIPT and not self.refusing:
                self._blocked_until_s = now_s + self.ack_delay_s
                self._finish_command(now_s, self._blocked_until_s)

    def _finish_command(self, now_s: float, due_s: float) -> None:
        """Write DONE once a path's plan is ready, a synchronous motion has ended and `due_s`
        (fault slow) has passed."""
        if self._path_command is not None:
            return  # command 45 waits for its plan
        if self._blocking_motion is not None and self._arm.motion is self._blocking_motion:
            return  # still inside a synchronous movel/movej
        if now_s < due_s:
            return  # fault slow: the answer comes late
        self._blocked_until_s = None
        self._blocking_motion = None
        self._set_out_int(0, DONE)

    def stop(self, reason: str, detail: dict[str, float] | None = None,
             at_s: float | None = None) -> None:
        """End the program (dashboard stop, pendant stop, 255, runtime error, watchdog); `detail`
        and the controller time it took effect (`at_s`, default now) go with the halted motion
        into the motion record."""
        if self.running:
            log.info("rtde_control program stopped: %s", reason)
        self.running = False
        self._path_motion = None
        self._path_command = None
        if self._async_motion is not None:
            self._async_motion = None
            self._write_async_word(-1)
        self._arm.halt(f"program stopped: {reason}", detail, at_s)

    def _watchdog_starved(self, now_s: float) -> bool:
        """rtde_set_watchdog(input_int_register_0 (+offset), f, "stop"), as ur_rtde's setWatchdog
        arms it: the program stops in the first control cycle after the input has gone 1/f s
        without an update. Checked every cycle, also while a synchronous move blocks the script;
        a cycle that runs late stops the arm where the previous cycle left it, and the stop is
        recorded at the cycle it was due. A frequency <= 0 (which URScript does not document)
        counts as starved at once."""
        if self._watchdog_hz is None:
            return False
        last_update_s = self._reg.in_int_written_s[self._off]
        period_s = self._arm.cycle_s
        allowed_cycles = math.floor(1.0 / self._watchdog_hz / period_s + 1e-9) + 1 if (
            self._watchdog_hz > 0) else 0
        due_s = last_update_s + allowed_cycles * period_s
        if now_s < due_s - 1e-9:
            return False
        self.stop(f"RTDE watchdog: input_int_register_{self._off} not updated for "
                  f"{due_s - last_update_s:.3f} s, minimum frequency {self._watchdog_hz} Hz",
                  {"watchdog_last_update_t": last_update_s,
                   "watchdog_min_frequency_hz": self._watchdog_hz}, at_s=min(due_s, now_s))
        return True

    # --- commands -----------------------------------------------------------------------------

    def _process(self, cmd: int) -> None:
        try:
            self._dispatch(cmd)
        except UnreachableError as exc:
            # A real controller raises a URScript runtime error here and the program stops.
            self.stop(f"command {cmd}: {exc}")

    def _dispatch(self, cmd: int) -> None:
        arm = self._arm
        if cmd in MOTION_KINDS:
            self._move(cmd)
        elif cmd == MOVE_PATH:
            self._move_path()
        elif cmd in (15, 33, 34):
            self._stop_move({15: "speedStop", 33: "stopL", 34: "stopJ"}[cmd])
        elif cmd in PAYLOAD_KINDS:
            self._set_payload(PAYLOAD_KINDS[cmd])
        elif cmd == 29:
            arm.set_tcp(self._in_doubles(0))
        elif cmd == 31:
            self._record({"kind": "triggerProtectiveStop"})
            self._protective_stop("triggerProtectiveStop() from the client")
        elif cmd == 35:
            self._watchdog_hz = float(self._in_doubles(0, 1)[0])
            log.info("RTDE watchdog on input_int_register_%d at %s Hz", self._off,
                     self._watchdog_hz)
        elif cmd == 36:
            self._set_out_int(1, int(arm.pose_within_limits(self._in_doubles(0))))
        elif cmd == 37:
            self._set_out_int(1, int(kin.within_limits(arm.model, self._in_doubles(0))))
        elif cmd == 39:
            T = kin.pose_to_matrix(self._in_doubles(0)) @ kin.pose_to_matrix(self._in_doubles(6))
            self._set_out_doubles(kin.matrix_to_pose(T))
        elif cmd == 40:
            self._set_out_doubles(arm.tcp_offset)
        elif cmd == 43:
            self._set_out_doubles(arm.actual_tcp_pose)  # get_forward_kin() at the actual joints
        elif cmd == 44:
            # The script always reads a TCP from D6-D11; getForwardKinematics(q) leaves whatever
            # an earlier command wrote there (faithful to the real script).
            T = arm.tcp_from_q(self._in_doubles(0), self._in_doubles(6))
            self._set_out_doubles(kin.matrix_to_pose(T))
        elif cmd in (30, 46):
            q_near = self._in_doubles(6) if cmd == 30 else None
            q = arm.ik_tcp(self._in_doubles(0), q_near)
            if q is None:
                raise UnreachableError(f"get_inverse_kin: no solution for "
                                       f"{self._in_doubles(0).round(6).tolist()}")
            self._set_out_doubles(q)
        elif cmd == 47:
            self._set_out_int(1, int(arm.steady))
        elif cmd == 58:
            self._set_out_doubles(arm.actual_flange_pose)
        elif cmd in (60, 61):
            q_near = self._in_doubles(6) if cmd == 61 else None
            self._set_out_int(1, int(arm.ik_tcp(self._in_doubles(0), q_near) is not None))
        elif cmd == STOP_SCRIPT:
            self.stop("stop script command (255) from the client")
        else:
            log.error(
                "SIMULATED CONTROLLER: command id %d is not implemented; stopping the program "
                "as a URScript runtime error would (the client call returns False)", cmd,
            )
            self.stop(f"unimplemented command id {cmd}")

    def _record(self, entry: dict[str, Any]) -> None:
        self._commands.add({"t": self._now_s, **{key: _plain(v) for key, v in entry.items()}})

    def _set_payload(self, kind: str) -> None:
        """set_payload(mass, cog) / set_target_payload(mass, cog, inertia): kg, m in the tool
        flange frame, kg m^2. A zero CoG keeps the current one (setPayload only), as the script
        does from PolyScope 5.0."""
        arm = self._arm
        mass, cog = float(self._in_doubles(0, 1)[0]), self._in_doubles(1, 3)
        entry: dict[str, Any] = {"kind": kind, "mass": mass, "cog": cog}
        arm.payload_kg = mass
        if kind == "setTargetPayload" or np.any(cog != 0.0):
            arm.payload_cog_m = cog
        if kind == "setTargetPayload":
            arm.payload_inertia = self._in_doubles(4, 6)
            entry["inertia"] = arm.payload_inertia
        self._record(entry)

    def _move(self, cmd: int) -> None:
        target = self._in_doubles(0)
        speed, accel = (float(v) for v in self._in_doubles(6, 2))
        is_async = self._in_int(1) == 1
        kind = MOTION_KINDS[cmd]
        entry: dict[str, Any] = {"kind": kind, "target": target, "speed": speed, "accel": accel,
                                 "async": is_async}
        if self._take_refused_move():
            self.refusing = True
            log.warning("fault refuse-move: refusing %s", kind)
            self._record({**entry, "refused": True})
            return
        self._record(entry)
        self._stop_async_move()
        arm = self._arm
        if kind == "moveJ":
            motion = arm.move_joint(target, speed, accel, kind)
        elif kind == "moveJ_IK":
            q = arm.ik_tcp(target)
            if q is None:
                raise UnreachableError(f"moveJ_IK target {target.round(6).tolist()} has no IK "
                                       f"solution")
            motion = arm.move_joint(q, speed, accel, kind)
        elif kind == "moveL":
            motion = arm.move_linear(target, speed, accel, kind)
        else:
            motion = arm.move_linear(kin.matrix_to_pose(arm.tcp_from_q(target)), speed, accel,
                                     kind)
        if is_async:
            self._async_motion = motion
            self._write_async_word(0)
        else:
            self._blocking_motion = motion

    def _move_path(self) -> None:
        """Command 45: exec_move_path(), in the move thread when I1 says async."""
        is_async = self._in_int(1) == 1
        path = self._path
        waypoints = () if path is None else path.waypoints
        entry: dict[str, Any] = {
            "kind": "movePath", "move": None if path is None else path.move,
            "waypoints": [list(w.target) for w in waypoints],
            "speeds": [w.speed for w in waypoints], "accels": [w.accel for w in waypoints],
            "radii": [w.blend for w in waypoints], "async": is_async,
        }
        if self._take_refused_move():
            self.refusing = True
            log.warning("fault refuse-move: refusing movePath")
            self._record({**entry, "refused": True})
            return
        self._stop_async_move()
        if path is None:  # nothing injected: exec_move_path() returns at once
            self._record(entry)
            if is_async:
                self._write_async_word(0)
                self._write_async_word(-1)
            return
        arm = self._arm
        plan = self._plan
        if plan is None or not plan.fits(arm.q, arm.tcp_offset):
            plan = self._plan = self._planner.request(arm.model, arm.q, arm.tcp_offset, path)
        self._path_command = (plan, entry)
        self._start_planned_path()

    def _start_planned_path(self) -> None:
        """Start command 45's path if its plan is ready (else try again next cycle). A path that
        cannot run (a waypoint without IK, a zero speed) stops the program, as a URScript runtime
        error does."""
        assert self._path_command is not None
        plan, entry = self._path_command
        if not plan.ready:
            return
        self._path_command = None
        try:
            planned = plan.result()
        except UnreachableError as exc:
            self.stop(f"command {MOVE_PATH}: {exc}")
            return
        motion = self._arm.start_path(planned.path, planned.q_end)
        assert motion.path is not None
        if motion.path.skipped:
            log.warning("movePath: blends at waypoints %s skipped (they would overlap a "
                        "neighbour's or not fit): the arm stops there", list(motion.path.skipped))
        self._record({**entry, "skipped_blends": list(motion.path.skipped),
                      **self._arm.planned_times(motion)})
        if entry["async"]:
            self._async_motion = motion
            self._write_async_word(0)  # the move thread: signal_async_operation_started()
        else:
            self._blocking_motion = motion
        self._path_motion = motion
        self._path_progress = 0
        self._write_async_word(0)  # the first line of the path: signal_async_progress(0)

    def _signal_path_progress(self) -> None:
        """signal_async_progress(i) for each waypoint i the arm has started heading for: the
        previous waypoint's move was done (its blend began, or the arm stopped there)."""
        motion = self._path_motion
        if motion is None or motion.path is None:
            return
        last = len(motion.path.done_distance) - 1
        while self._path_progress < min(len(motion.reached_s), last):
            self._path_progress += 1
            self._write_async_word(self._path_progress)
        if self._arm.motion is not motion:
            self._path_motion = None

    def _stop_async_move(self) -> None:
        """A new move kills the running async move: the arm halts, the word says finished."""
        self._path_motion = None
        if self._async_motion is not None:
            self._async_motion = None
            self._arm.halt("replaced by a new move")
            self._write_async_word(-1)

    def _stop_move(self, kind: str) -> None:
        """stopL/stopJ (sync or async) and speedStop: brake at D0 until the arm is still."""
        decel = float(self._in_doubles(0, 1)[0])
        is_async = kind != "speedStop" and self._in_int(1) == 1
        entry: dict[str, Any] = {"kind": kind, "accel": decel}
        if kind != "speedStop":
            entry["async"] = is_async
        self._record(entry)
        self._path_motion = None  # a path's thread is killed too: it signals no more waypoints
        if self._async_motion is not None:  # the move thread is killed; the arm brakes below
            self._async_motion = None
            self._write_async_word(-1)
        braking = self._arm.decelerate(decel)
        if is_async:
            self._write_async_word(0)  # the stop thread starts
            if braking is None:
                self._write_async_word(-1)
            else:
                self._async_motion = braking
        elif braking is not None:
            self._blocking_motion = braking  # stopl/stopj block until the arm is still


def _plain(value: Any) -> Any:
    """JSON-friendly: numpy vectors and scalars become Python lists and floats."""
    if isinstance(value, np.ndarray):
        return [float(v) for v in value]
    if isinstance(value, np.floating):
        return float(value)
    return value


class PendantProgram:
    """A program started from the pendant (dashboard `play` of the loaded program), named after
    its file (`pick.urp`): it plays until stopped and does nothing the simulation needs. It does
    not speak ur_rtde's register protocol: a command id in the registers, 255 included, means
    nothing to it, and it writes no output register."""

    refusing = False
    ack_delay_s = 0.0

    def __init__(self, name: str):
        self.name = name
        self.running = True

    def cycle(self, now_s: float) -> None:
        """Nothing to do in a control cycle."""

    def stop(self, reason: str, detail: dict[str, float] | None = None,
             at_s: float | None = None) -> None:
        """End the program (dashboard stop, a new program, a safety stop); no motion to halt."""
        if self.running:
            log.info("pendant program %s stopped: %s", self.name, reason)
        self.running = False
