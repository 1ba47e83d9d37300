"""Controller: the engine of the simulated UR controller, on one loopback address.

Serves RTDE (30004), dashboard (29999) and the script port (30003) as the profile has them (see
profiles.py), so the unmodified ur_rtde 1.6.5 client connects as to a real robot, and the admin
channel (admin.py) for run-time faults. One control-loop thread (500 Hz e-Series, 125 Hz CB3) owns
the state: each cycle it runs the control script's main-loop pass (the client's inputs as last
written), advances the motion, fires due faults and publishes the outputs that RTDE sender
threads stream.

Controller time: cycle N is stamped N control periods after start, with N taken from the wall
clock. A cycle that comes late (the machine was busy) advances the motion by the whole time
since the last one and skips the missed stamps, as a real controller's RTDE drops packages:
stamps are never compressed and never lie.

Poses are UR vectors [x, y, z, rx, ry, rz] in metres and radians; joints in radians.
"""

from __future__ import annotations

import ipaddress
import logging
import math
import sys
import threading
import time
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from mocks.ur_controller import kinematics as kin
from mocks.ur_controller.admin import AdminServer
from mocks.ur_controller.arm import Arm, UnreachableError, Vector, default_q
from mocks.ur_controller.dashboard import DashboardServer
from mocks.ur_controller.faults import FaultSpec, parse_fault
from mocks.ur_controller.gripper import Robotiq2F, RobotiqServer, answer
from mocks.ur_controller.net import Listener
from mocks.ur_controller.options import ControllerOptions
from mocks.ur_controller.outputs import Io, Modes, OutputTable
from mocks.ur_controller.path_plan import PathPlanner, PlanRequest
from mocks.ur_controller.path_script import PathSpec, PathSyntaxError, injected_path
from mocks.ur_controller.profiles import PROFILES, Profile
from mocks.ur_controller.program import ControlScript, PendantProgram, Registers
from mocks.ur_controller.record import CommandRecord
from mocks.ur_controller.rtde import RtdeServer
from mocks.ur_controller.script_port import ScriptPort, register_offsets
from mocks.ur_controller.snapshot import ControllerSnapshot

log = logging.getLogger("mocks.ur_controller")

ROBOT_MODE_POWER_OFF = 3
ROBOT_MODE_IDLE = 5
ROBOT_MODE_RUNNING = 7
SAFETY_NORMAL = 1
SAFETY_PROTECTIVE_STOP = 3
SAFETY_SAFEGUARD_STOP = 5
SAFETY_ROBOT_EMERGENCY_STOP = 7
RUNTIME_STOPPED = 1
RUNTIME_PLAYING = 2
RUNTIME_PAUSING = 3
RUNTIME_PAUSED = 4
GIL_SWITCH_S = 0.0002
"""The interpreter hands the GIL to a waiting thread after this long (s): well under a control
cycle, so no other thread of the simulator holds up the control loop or a sender for long."""
MAX_LAG_S = 0.5
"""The control loop catches up at most this far behind the wall clock (s): a process frozen for
longer (SIGSTOP, swapping) resumes with its clock slipped, not with a burst of cycles."""


def _vector(values: Sequence[float], what: str) -> Vector:
    arr = np.asarray(values, dtype=np.float64)
    if arr.shape != (6,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"Controller: {what} must be 6 finite numbers, got {values!r}")
    return arr


class Controller:
    """The simulated controller, serving in this process; see README.md for the contract.

    ur_rtde's constructors hold the GIL while they wait for the server, so clients must live in
    another process: tests use SimulatedController, which runs this class in a child process.
    """

    def __init__(self, options: ControllerOptions):
        self.profile, self.model_name = _profile_and_model(options)
        self.host = options.host
        self.lock = threading.RLock()
        self._cycle_s = 1.0 / self.profile.cycle_hz
        ur_model = kin.ALL_MODELS[self.model_name]
        start_q = _start_q(options, ur_model)
        tcp_offset = _vector(options.tcp_offset, "tcp_offset")
        self.arm = Arm(ur_model, start_q, tcp_offset, options.speed_factor, options.instant,
                       self._cycle_s, tracking_seed=options.seed if options.tracking else None)
        self.registers = Registers()
        self.gripper = Robotiq2F(time_scale=options.speed_factor, instant=options.instant,
                                 part_width_mm=_width(options.part_width_mm))
        self._feedback = _feedback_bits(options.feedback_input)
        self._record = CommandRecord(options.record_path)
        self._motions = CommandRecord(options.motion_record_path)
        # The target TCP pose and joints of every cycle a motion moved, by motion index
        # (trace_tcp only)
        self._trace: dict[int, list[list[float]]] | None = {} if options.trace_tcp else None
        self._q_trace: dict[int, list[list[float]]] = {}
        # The digital outputs (standard | configurable << 8 | tool << 16) at each traced
        # motion's first moving cycle: whether a digital gripper held its fingers closed.
        self._out_trace: dict[int, int] = {}
        self._faults = [parse_fault(spec) for spec in options.inject]
        # The state the control loop owns: modes, program, outputs as last written, one-shots.
        self._script: ControlScript | PendantProgram | None = None
        # A received program waits before it runs (controller time): a fixed time, the profile's
        # start cost for its length, or not at all. Pending: (due, offset, path, its plan).
        self._program_start_s = options.program_start_s
        self._program_start_cost = options.program_start_cost
        self._pending_program: tuple[float, int, PathSpec | None, PlanRequest | None] | None = None
        self._planner = PathPlanner()
        self._paused = False
        self._robot_mode = ROBOT_MODE_RUNNING
        self._safety_mode = SAFETY_NORMAL
        self._remote_control = options.remote_control
        self._refuse_next_start = False
        self._refuse_next_move = False
        self._stall_until_s = 0.0
        self._slow_s = 0.0
        self._standard_do = 0
        self._plc_inputs = 0  # standard digital inputs a PLC drives (admin set_inputs)
        self._configurable_do = 0
        self._tool_do = 0
        self._analog_out = [0.0, 0.0]
        self._analog_io_types = 0
        self._time_s = 0.0
        self._clock_start_s = time.monotonic()  # wall time of controller time 0 (the loop's)
        self._output_table = OutputTable(self.profile.output_types)
        self._outputs: Mapping[str, object] = {}
        self._stopping = threading.Event()
        self._loop: threading.Thread | None = None
        self._rtde = RtdeServer(options.host, self, self.profile)
        self._dashboard = (DashboardServer(options.host, self, self.profile, self.model_name)
                           if self.profile.dashboard else None)
        self._listeners = self._servers(options.host)
        with self.lock:
            self._publish()

    def _servers(self, host: str) -> tuple[Listener, ...]:
        """Every port's listener: the profile's, the Robotiq socket, the admin channel."""
        listeners: list[Listener] = [self._rtde.listener]
        if self._dashboard is not None:
            listeners.append(self._dashboard.listener)
        if self.profile.script_port:
            listeners.append(ScriptPort(host, self.run_program).listener)
        listeners.append(RobotiqServer(host, self.gripper_request).listener)
        if ipaddress.ip_address(host).is_loopback:  # never offer the admin channel off the box
            listeners.append(AdminServer(host, self).listener)
        return tuple(listeners)

    # --- lifetime ---------------------------------------------------------------------------

    def start(self) -> Controller:
        """Start the control loop and listen on the profile's ports; returns when listening.

        Also shortens this process's GIL switch interval to GIL_SWITCH_S: with Python's default
        (5 ms) a thread doing long work (the path planner) kept the control loop and the RTDE
        senders waiting for the interpreter for several control cycles at a time."""
        sys.setswitchinterval(GIL_SWITCH_S)
        with self.lock:
            if self.profile.control_script_running:
                self._start_script(0, "started from the pendant (profile " +
                                   self.profile.name + ")")
            for fault in [f for f in self._faults if f.move_index is None]:
                self._faults.remove(fault)
                self._apply(fault)
        self._loop = threading.Thread(target=self._run, name="control-loop", daemon=True)
        self._loop.start()
        try:
            for listener in self._listeners:
                listener.start()
        except OSError:
            self.stop()
            raise
        return self

    def stop(self) -> None:
        """Close every port and connection, stop the control loop, close the record file."""
        for listener in self._listeners:
            listener.close()
        self._stopping.set()
        if self._loop is not None:
            self._loop.join(timeout=2.0)
        self._planner.close()
        self._record.close()
        self._motions.close()

    def __enter__(self) -> Controller:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.stop()

    # --- public API -------------------------------------------------------------------------

    @property
    def ports(self) -> dict[str, int]:
        """The ports this controller serves, by name (rtde, dashboard, script, admin)."""
        return {listener.name: listener.port for listener in self._listeners}

    @property
    def commands(self) -> list[dict[str, Any]]:
        """A copy of the command record: one dict per motion, stop or payload command, in order."""
        return self._record.entries()

    @property
    def motions(self) -> list[dict[str, Any]]:
        """A copy of the motion record: one dict per motion once it has ended, in order."""
        return self._motions.entries()

    @property
    def dashboard_connections(self) -> list[dict[str, Any]]:
        """A copy of the dashboard's connection record (dashboard.py); empty without one."""
        return [] if self._dashboard is None else self._dashboard.connections()

    def inject(self, spec: str) -> None:
        """Inject a fault, `FAULT@WHEN` (`@now` implied); see faults.py for the names."""
        fault = parse_fault(spec)
        with self.lock:
            if fault.move_index is None:
                self._apply(fault)
            else:
                self._faults.append(fault)

    def set_part(self, width_mm: float | None) -> None:
        """Script the part: present with this width (mm) at the gripper, or absent (None)."""
        with self.lock:
            self.gripper.part_width_mm = _width(width_mm)

    def gripper_request(self, request: str) -> str | None:
        """One line on the Robotiq socket: the reply, or None when the gripper is silent."""
        with self.lock:
            return answer(self.gripper, request)

    def set_remote_control(self, enabled: bool) -> None:
        """Switch remote/local control, as on the pendant; ValueError on a profile without it."""
        if not self.profile.remote_control_mode:
            raise ValueError(f"the {self.profile.name} profile has no remote control mode")
        with self.lock:
            self._remote_control = enabled

    def set_inputs(self, inputs: Mapping[int, bool]) -> None:
        """Drive standard digital inputs 0-7 as a PLC wired to the control box would."""
        for bit, value in inputs.items():
            if not 0 <= bit <= 7:
                raise ValueError(f"standard digital input {bit}: expected 0-7")
            with self.lock:
                self._plc_inputs = (self._plc_inputs | 1 << bit if value
                                    else self._plc_inputs & ~(1 << bit))

    def snapshot(self) -> ControllerSnapshot:
        with self.lock:
            arm = self.arm
            return ControllerSnapshot(
                q=tuple(arm.q.tolist()),
                flange_pose=tuple(arm.flange_pose.tolist()),
                tcp_pose=tuple(arm.tcp_pose.tolist()),
                actual_tcp_pose=tuple(arm.actual_tcp_pose.tolist()),
                tcp_offset=tuple(arm.tcp_offset.tolist()),
                robot_mode=self._robot_mode,
                safety_mode=self._safety_mode,
                runtime_state=self._runtime_state(),
                program_running=self._runtime_state() == RUNTIME_PLAYING,
                remote_control=self._remote_control,
                moving=arm.motion is not None,
                steady=arm.steady,
                standard_digital_out=self._standard_do,
                tool_digital_out=self._tool_do,
                configurable_digital_out=self._configurable_do,
                payload_kg=arm.payload_kg,
                payload_cog=tuple(arm.payload_cog_m.tolist()),
                digital_inputs=self._digital_input_bits(),
                gripper_position=self.gripper.get("POS"),
                gripper_object=self.gripper.obj,
                part_present=self.gripper.part_width_mm is not None,
                time_s=self._time_s,
                profile=self.profile.name,
            )

    # --- program control (script port, dashboard) -------------------------------------------

    def run_program(self, program: str) -> None:
        """Run a program received on 30003; a new program replaces the running one. One whose
        injected path does not compile is not started (logged, recorded as compileError); its
        path is planned at once, off the control thread (path_plan.py). With `program_start_s`,
        or the profile's start cost (`program_start_cost`), the program runs that long after it
        arrived, as a controller takes time to compile and start it: meanwhile no program runs
        and the stream goes on."""
        with self.lock:
            if "def rtde_control():" not in program:
                log.warning("script port: ignoring a program that is not ur_rtde's "
                            "rtde_control (%d bytes)", len(program))
                return
            refusal = self._start_refusal()
            if refusal:
                log.warning("script port: not starting rtde_control: %s", refusal)
                return
            try:
                path = injected_path(program)
            except PathSyntaxError as exc:
                log.error("script port: rtde_control does not compile, not started: %s", exc)
                self._record.add({"t": self._time_s, "kind": "compileError", "error": str(exc)})
                self.stop_program("replaced by a program that does not compile")
                return
            offset = register_offsets(program)
            if self._script is not None:
                self._script.stop("replaced by a new program")
            arm = self.arm
            plan = (None if path is None
                    else self._planner.request(arm.model, arm.q, arm.tcp_offset, path))
            start_s = self._start_delay_s(program)
            if start_s <= 0.0:
                self._start_script(offset, "received on the script port", path, plan)
                return
            log.info("rtde_control received (%d lines): starts in %.3f s", program.count("\n"),
                     start_s)
            self._pending_program = (self._time_s + start_s, offset, path, plan)

    def _start_delay_s(self, program: str) -> float:
        """Controller time (s) from receiving `program` to running it: program_start_s, or with
        program_start_cost the profile's cost per line times its lines, at the speed factor."""
        if not self._program_start_cost:
            return self._program_start_s
        lines = program.count("\n")
        return lines * self.profile.program_start_s_per_line / self.arm.speed_factor

    def _start_script(self, register_offset: int, how: str, path: PathSpec | None = None,
                      plan: PlanRequest | None = None) -> None:
        if self._script is not None:
            self._script.stop("replaced by a new program")
        self._pending_program = None
        self._paused = False
        self._script = ControlScript(self.registers, self.arm, self._record, register_offset,
                                     self._protective_stop, self._take_refused_move, self._time_s,
                                     self._planner, path, plan)
        self._script.ack_delay_s = self._slow_s
        log.info("rtde_control program started (%s)", how)

    def _take_refused_move(self) -> bool:
        refuse, self._refuse_next_move = self._refuse_next_move, False
        return refuse

    def _start_refusal(self) -> str:
        if self.profile.remote_control_mode and not self._remote_control:
            return "the robot is in local control"
        if self._robot_mode != ROBOT_MODE_RUNNING:
            return f"robot mode is {self._robot_mode}, expected 7 (RUNNING)"
        if self._safety_mode != SAFETY_NORMAL:
            return f"safety mode is {self._safety_mode}, expected 1 (NORMAL)"
        return ""

    def program_name(self) -> str:
        return "<unnamed>" if self._script is None else self._script.name

    def stop_program(self, reason: str) -> None:
        with self.lock:
            self._pending_program = None
            if self._script is not None:
                self._script.stop(reason)
            self._paused = False

    def pause_program(self) -> bool:
        with self.lock:
            if self._runtime_state() != RUNTIME_PLAYING:
                return False
            self._paused = True
            self.arm.halt("program paused")
            return True

    def play_program(self, loaded: str) -> bool:
        """The pendant's play: resume a paused program, or start the `loaded` one (a path,
        empty when none is loaded) when none runs; False otherwise."""
        with self.lock:
            if self._runtime_state() == RUNTIME_PAUSED and self._safety_mode == SAFETY_NORMAL:
                self._paused = False
                return True
            if self._runtime_state() != RUNTIME_STOPPED or not loaded or self._start_refusal():
                return False
            self._pending_program = None
            self._script = PendantProgram(loaded.rsplit("/", 1)[-1])
            log.info("pendant program %s started (dashboard play)", self._script.name)
            return True

    def power_on(self) -> bool:
        with self.lock:
            if self._robot_mode != ROBOT_MODE_POWER_OFF or self._safety_mode != SAFETY_NORMAL:
                return False
            self._robot_mode = ROBOT_MODE_IDLE
            return True

    def power_off(self) -> None:
        with self.lock:
            self.stop_program("power off")
            self._robot_mode = ROBOT_MODE_POWER_OFF

    def release_brakes(self) -> bool:
        with self.lock:
            if self._robot_mode != ROBOT_MODE_IDLE:
                return False
            self._robot_mode = ROBOT_MODE_RUNNING
            return True

    def unlock_protective_stop(self) -> bool:
        with self.lock:
            if self._safety_mode != SAFETY_PROTECTIVE_STOP:
                return False
            self._safety_mode = SAFETY_NORMAL
            return True

    def close_safety_popup(self) -> None:
        """Acknowledge a safeguard stop: safety back to NORMAL, the program stays paused."""
        with self.lock:
            if self._safety_mode == SAFETY_SAFEGUARD_STOP:
                self._safety_mode = SAFETY_NORMAL

    def restart_safety(self) -> None:
        """Clear any safety stop; the robot comes back powered off with no program running."""
        with self.lock:
            if self._safety_mode != SAFETY_NORMAL:
                self.stop_program("restart safety")
                self._safety_mode = SAFETY_NORMAL
                self._robot_mode = ROBOT_MODE_POWER_OFF

    # --- faults -----------------------------------------------------------------------------

    def _protective_stop(self, reason: str) -> None:
        log.warning("protective stop: %s", reason)
        self._safety_mode = SAFETY_PROTECTIVE_STOP
        self.arm.halt(f"protective stop: {reason}")

    def _apply(self, fault: FaultSpec) -> None:
        log.warning("fault injected: %s", fault)
        if fault.name == "protective-stop":
            self._protective_stop("injected fault")
        elif fault.name == "emergency-stop":
            self.stop_program("robot emergency stop")
            self._safety_mode = SAFETY_ROBOT_EMERGENCY_STOP
            self._robot_mode = ROBOT_MODE_POWER_OFF
        elif fault.name == "safeguard-stop":
            self._safety_mode = SAFETY_SAFEGUARD_STOP
            self._paused = self._script is not None and self._script.running
            self.arm.halt("safeguard stop")
        elif fault.name == "drop-connection":
            for listener in self._listeners:
                listener.drop_clients()
        elif fault.name == "stall":
            self._stall_until_s = time.monotonic() + (fault.seconds or 0.0)
        elif fault.name == "stop-program":
            self.stop_program("stopped from the pendant")
        elif fault.name == "remote-control-off":
            self._remote_control = False
        elif fault.name == "dashboard-down" and self._dashboard is not None:
            self._dashboard.go_away()
        elif fault.name == "refuse-start":
            self._refuse_next_start = True
        elif fault.name == "refuse-move":
            self._refuse_next_move = True
        elif fault.name == "gripper-fault":
            self.gripper.flt = fault.code or 0
        elif fault.name == "gripper-silent":
            self.gripper.silent = True
        elif fault.name == "gripper-drop":
            self.gripper.drop_part()
        elif fault.name == "jitter":
            self.arm.jitter(fault.seconds or 0.0)
        elif fault.name == "slow":
            self._slow_s = fault.seconds or 0.0
            if self._script is not None:
                self._script.ack_delay_s = self._slow_s

    # --- RTDE backend -----------------------------------------------------------------------

    def latest_outputs(self) -> Mapping[str, object]:
        return self._outputs

    def take_refused_start(self) -> bool:
        with self.lock:
            refused, self._refuse_next_start = self._refuse_next_start, False
            return refused

    def stream_stalled(self) -> bool:
        return time.monotonic() < self._stall_until_s

    def write_inputs(self, values: Mapping[str, object]) -> None:
        """Apply one client data package: registers, and the IO fields with their masks."""
        with self.lock:
            self._write_registers(values)
            self._standard_do = _masked(values, "standard_digital_output", self._standard_do)
            self._configurable_do = _masked(values, "configurable_digital_output",
                                            self._configurable_do)
            self._tool_do = _masked(values, "tool_digital_output", self._tool_do)
            if values.get("speed_slider_mask") == 1:
                self.arm.speed_slider = min(1.0, max(0.0, _number(values["speed_slider_fraction"])))
            analog_mask = values.get("standard_analog_output_mask", 0)
            analog_type = values.get("standard_analog_output_type", 0)
            for i in (0, 1):
                if isinstance(analog_mask, int) and analog_mask & (1 << i):
                    self._analog_out[i] = _number(values[f"standard_analog_output_{i}"])
                    if isinstance(analog_type, int):  # bits 2-3 of analog_io_types: outputs
                        voltage = analog_type >> i & 1
                        self._analog_io_types = (self._analog_io_types & ~(1 << (2 + i))
                                                 | voltage << (2 + i))

    def _write_registers(self, values: Mapping[str, object]) -> None:
        regs = self.registers
        arrived_s = (time.monotonic() - self._clock_start_s) // self._cycle_s * self._cycle_s
        for name, value in values.items():
            prefix, _, number = name.rpartition("_")
            if prefix == "input_int_register":
                regs.in_int[int(number)] = int(_number(value))
                regs.in_int_fresh[int(number)] = arrived_s
            elif prefix == "input_double_register":
                regs.in_double[int(number)] = _number(value)
            elif prefix == "input_bit_register":
                regs.in_bits[int(number)] = bool(value)
            elif name in ("input_bit_registers0_to_31", "input_bit_registers32_to_63"):
                first = 0 if name.endswith("0_to_31") else 32
                word = int(_number(value))
                regs.in_bits[first : first + 32] = [bool(word >> i & 1) for i in range(32)]

    # --- the control loop -------------------------------------------------------------------

    def _run(self) -> None:
        """Run control cycles 1, 2, 3, ... each at its own controller time (N periods), none
        ever skipped. A cycle the machine delays (the process was descheduled) runs as soon as
        the loop gets the CPU, and the cycles owed after it run back to back, so every cycle's
        RTDE sample goes out, late but in order; a loop more than MAX_LAG_S behind the wall
        clock lets its clock slip instead (controller time then runs behind the wall clock)."""
        period_s = self._cycle_s
        self._clock_start_s = time.monotonic()
        cycle = 0
        while not self._stopping.is_set():
            cycle += 1
            delay_s = self._clock_start_s + cycle * period_s - time.monotonic()
            if delay_s > 0:
                self._stopping.wait(delay_s)
            elif delay_s < -MAX_LAG_S:
                self._clock_start_s -= delay_s + MAX_LAG_S  # slip: catch up at most MAX_LAG_S
            with self.lock:
                try:
                    self._cycle(period_s, cycle * period_s)
                except Exception:
                    log.exception("control loop cycle failed")
            self._rtde.cycle_done(cycle)  # its RTDE packages go out now, as on a real UR

    def _cycle(self, dt_s: float, time_s: float) -> None:
        self._time_s = time_s
        self.arm.now_s = time_s
        self.registers.take_in_writes(time_s)  # a controller applies RTDE inputs at a cycle
        pending = self._pending_program
        if pending is not None and time_s >= pending[0] - 1e-9:
            self._start_script(pending[1], "received on the script port, started after its "
                                           "start time", pending[2], pending[3])
        script = self._script
        if (script is not None and self._runtime_state() == RUNTIME_PLAYING
                and self._safety_mode == SAFETY_NORMAL):
            script.cycle(time_s)
        try:
            motion = self.arm.advance(dt_s, time_s)
        except UnreachableError as exc:
            self._protective_stop(str(exc))
            motion = None
        if motion is not None:
            self._fire_move_faults(motion.index, motion.fraction)
            if self._trace is not None:
                self._trace.setdefault(motion.index, []).append(self.arm.tcp_pose.tolist())
                self._q_trace.setdefault(motion.index, []).append(self.arm.q.tolist())
                self._out_trace.setdefault(motion.index, self._digital_outputs())
        self.gripper.advance(dt_s)
        self._record_ended_motions()
        self._publish()

    def _record_ended_motions(self) -> None:
        for end in self.arm.ended:
            motion = end.motion
            self._motions.add({
                "motion": motion.index, "kind": motion.kind, "start_t": motion.started_s,
                "end_t": end.end_s, "moving_s": end.end_s - motion.started_s, "end": end.reason,
                **(end.detail or {}),
                **({} if motion.path is None else {"reached_t": list(motion.reached_s)}),
                **({} if self._trace is None
                   else {"tcp_trace": self._trace.pop(motion.index, []),
                         "q_trace": self._q_trace.pop(motion.index, []),
                         "digital_out": self._out_trace.pop(motion.index, 0)}),
            })
        self.arm.ended.clear()

    def _fire_move_faults(self, index: int, fraction: float) -> None:
        due = [f for f in self._faults if f.move_index == index and fraction >= f.fraction]
        for fault in due:
            self._faults.remove(fault)
            self._apply(fault)

    def _digital_outputs(self) -> int:
        """Every digital output as one word: standard 0-7, configurable 8-15, tool 16-17."""
        return self._standard_do | self._configurable_do << 8 | self._tool_do << 16

    def _digital_input_bits(self) -> int:
        """actual_digital_input_bits: the inputs a PLC drives (set_inputs), and the feedback
        input, if configured, which reads true while its gripper output is on and the scripted
        part is present."""
        if self._feedback is None:
            return self._plc_inputs
        output_bit, input_bit = self._feedback
        outputs = self._digital_outputs()
        sensed = bool(outputs >> output_bit & 1) and self.gripper.part_width_mm is not None
        return self._plc_inputs | int(sensed) << input_bit

    def _runtime_state(self) -> int:
        if self._script is None or not self._script.running:
            return RUNTIME_STOPPED
        return RUNTIME_PAUSED if self._paused else RUNTIME_PLAYING

    def _publish(self) -> None:
        """Build every output variable's value for the RTDE senders (replaced, never mutated)."""
        runtime_state = self._runtime_state()
        if runtime_state == RUNTIME_PLAYING and self._script is not None and self._script.refusing:
            runtime_state = RUNTIME_PAUSING  # how a refused command reaches ur_rtde (program.py)
        modes = Modes(self._robot_mode, self._safety_mode, runtime_state)
        io = Io(self._standard_do, self._configurable_do, self._tool_do, self._digital_input_bits(),
                (self._analog_out[0], self._analog_out[1]), self._analog_io_types)
        self._outputs = self._output_table.build(self._time_s, self.arm, modes, io,
                                                 self.registers)


def _profile_and_model(options: ControllerOptions) -> tuple[Profile, str]:
    """The profile and the arm's model name; ValueError for options that do not fit together."""
    if not ipaddress.ip_address(options.host).is_loopback and not options.allow_non_loopback:
        raise ValueError(f"Controller: host {options.host!r} is not a loopback address; "
                         f"pass --allow-non-loopback to serve on it")
    if options.profile not in PROFILES:
        raise ValueError(f"Controller: profile must be one of {sorted(PROFILES)}, "
                         f"got {options.profile!r}")
    profile = PROFILES[options.profile]
    model = profile.default_model if options.model is None else options.model
    if model not in profile.models:
        raise ValueError(f"Controller: model must be one of {list(profile.models)} "
                         f"for the {profile.name} profile, got {model!r}")
    if not options.speed_factor > 0:
        raise ValueError(f"Controller: speed_factor must be > 0, got {options.speed_factor}")
    if not options.program_start_s >= 0.0 or math.isinf(options.program_start_s):
        raise ValueError(f"Controller: program_start_s must be finite and >= 0, got "
                         f"{options.program_start_s}")
    if options.program_start_s and options.program_start_cost:
        raise ValueError("Controller: give program_start_s (a fixed time) or program_start_cost "
                         "(the profile's cost for the program's length), not both")
    if options.tracking and options.instant:
        raise ValueError("Controller: tracking needs real-time motion (--speed-factor): an "
                         "instant move ends at full speed, far ahead of a lagging arm")
    if options.initial_q is not None and options.initial_flange_pose is not None:
        raise ValueError("Controller: give initial_q or initial_flange_pose, not both")
    return profile, model


def _start_q(options: ControllerOptions, model: kin.URModel) -> Vector:
    """The joints the arm starts at: initial_q, the IK solution nearest the default joints for
    initial_flange_pose, or the default joints."""
    if options.initial_q is not None:
        return _vector(options.initial_q, "initial_q")
    if options.initial_flange_pose is None:
        return default_q()
    T = kin.pose_to_matrix(_vector(options.initial_flange_pose, "initial_flange_pose"))
    solution = kin.inverse(model, T, default_q())
    if solution is None:
        raise ValueError(f"Controller: initial_flange_pose {options.initial_flange_pose}"
                         f" is unreachable for {model.name}")
    return solution


def _width(width_mm: float | None) -> float | None:
    if width_mm is not None and not 0.0 <= width_mm <= 85.0:
        raise ValueError(f"Controller: a part width must be 0..85 mm, got {width_mm}")
    return width_mm


def _feedback_bits(feedback_input: Sequence[int] | None) -> tuple[int, int] | None:
    """(output bit, input bit): bits of actual_digital_output_bits / _input_bits (0-17)."""
    if feedback_input is None:
        return None
    bits = tuple(int(b) for b in feedback_input)
    if len(bits) != 2 or not all(0 <= b <= 17 for b in bits):
        raise ValueError(f"Controller: feedback_input is (output bit, input bit), each 0..17, "
                         f"got {feedback_input!r}")
    return bits[0], bits[1]


def _masked(values: Mapping[str, object], name: str, bits: int) -> int:
    """Apply a `name`/`name_mask` pair of digital outputs, if the package carried it."""
    mask = values.get(f"{name}_mask")
    value = values.get(name)
    if not isinstance(mask, int) or not isinstance(value, int):
        return bits
    return (bits & ~mask) | (value & mask)


def _number(value: object) -> float:
    if not isinstance(value, (int, float)):
        raise TypeError(f"RTDE input: expected a number, got {value!r}")
    return float(value)
