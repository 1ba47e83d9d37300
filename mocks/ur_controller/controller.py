"""Controller: the engine of the simulated UR e-Series controller, on one loopback address.

Serves RTDE (30004), dashboard (29999) and the script port (30003) so the unmodified ur_rtde
1.6.5 client connects as to a real robot. One 500 Hz control-loop thread owns the state: each
cycle it runs the control script's main-loop pass (the client's inputs as last written), advances
the motion, fires due faults and publishes the outputs that RTDE sender threads stream.

Poses are UR vectors [x, y, z, rx, ry, rz] in metres and radians; joints in radians.
"""

from __future__ import annotations

import ipaddress
import logging
import threading
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mocks.ur_controller import kinematics as kin
from mocks.ur_controller.arm import Arm, UnreachableError, default_q
from mocks.ur_controller.dashboard import DashboardServer
from mocks.ur_controller.faults import FaultSpec, parse_fault
from mocks.ur_controller.program import ControlScript, Registers
from mocks.ur_controller.record import CommandRecord
from mocks.ur_controller.rtde import CYCLE_HZ, OUTPUT_TYPES, RtdeServer
from mocks.ur_controller.script_port import ScriptPort, register_offsets

log = logging.getLogger("mocks.ur_controller")

CYCLE_S = 1.0 / CYCLE_HZ  # e-Series control cycle, 2 ms
EXIT_CANNOT_LISTEN = 3  # command-line exit status: a port is taken or the address is not local

ROBOT_MODE_POWER_OFF = 3
ROBOT_MODE_IDLE = 5
ROBOT_MODE_RUNNING = 7
SAFETY_NORMAL = 1
SAFETY_PROTECTIVE_STOP = 3
SAFETY_SAFEGUARD_STOP = 5
SAFETY_ROBOT_EMERGENCY_STOP = 7
RUNTIME_STOPPED = 1
RUNTIME_PLAYING = 2
RUNTIME_PAUSED = 4
# safety_status_bits: 0 normal, 2 protective stopped, 4 safeguard stopped, 6 robot e-stop,
# 7 emergency stopped, 10 stopped due to safety.
_SAFETY_BITS = {
    SAFETY_NORMAL: 1 << 0,
    SAFETY_PROTECTIVE_STOP: (1 << 2) | (1 << 10),
    SAFETY_SAFEGUARD_STOP: (1 << 4) | (1 << 10),
    SAFETY_ROBOT_EMERGENCY_STOP: (1 << 6) | (1 << 7) | (1 << 10),
}
_JOINT_MODE_RUNNING = 253
_JOINT_MODE_POWER_OFF = 239


@dataclass(frozen=True)
class ControllerSnapshot:
    """The controller's state at one instant (units: rad, m, kg, s)."""

    q: tuple[float, ...]
    flange_pose: tuple[float, ...]
    tcp_pose: tuple[float, ...]  # includes tcp_offset
    tcp_offset: tuple[float, ...]
    robot_mode: int  # 7 RUNNING
    safety_mode: int  # 1 NORMAL, 3 PROTECTIVE_STOP, 5 SAFEGUARD_STOP, 7 ROBOT_EMERGENCY_STOP
    runtime_state: int  # 2 PLAYING, 1 STOPPED, 4 PAUSED
    program_running: bool
    remote_control: bool
    moving: bool
    standard_digital_out: int
    tool_digital_out: int
    configurable_digital_out: int
    payload_kg: float
    time_s: float


def _vector(values: Sequence[float], what: str) -> np.ndarray[Any, np.dtype[np.float64]]:
    arr = np.asarray(values, dtype=np.float64)
    if arr.shape != (6,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"Controller: {what} must be 6 finite numbers, got {values!r}")
    return arr


class Controller:
    """The simulated controller, serving in this process; see README.md for the contract.

    ur_rtde's constructors hold the GIL while they wait for the server, so clients must live in
    another process: tests use SimulatedController, which runs this class in a child process.
    """

    def __init__(
        self,
        host: str = "127.0.0.1",
        model: str = "ur5e",
        initial_q: Sequence[float] | None = None,
        initial_flange_pose: Sequence[float] | None = None,
        tcp_offset: Sequence[float] = (0, 0, 0, 0, 0, 0),
        speed_factor: float = 1.0,
        instant: bool = False,
        record_path: str | Path | None = None,
        inject: Iterable[str] = (),
        remote_control: bool = True,
        allow_non_loopback: bool = False,
    ):
        if not ipaddress.ip_address(host).is_loopback and not allow_non_loopback:
            raise ValueError(f"Controller: host {host!r} is not a loopback address; "
                             f"pass allow_non_loopback=True to serve on it")
        if model not in kin.MODELS:
            raise ValueError(f"Controller: model must be one of {sorted(kin.MODELS)}, "
                             f"got {model!r}")
        if not speed_factor > 0:
            raise ValueError(f"Controller: speed_factor must be > 0, got {speed_factor}")
        if initial_q is not None and initial_flange_pose is not None:
            raise ValueError("Controller: give initial_q or initial_flange_pose, not both")
        ur_model = kin.MODELS[model]
        q = default_q()
        if initial_q is not None:
            q = _vector(initial_q, "initial_q")
        elif initial_flange_pose is not None:
            T = kin.pose_to_matrix(_vector(initial_flange_pose, "initial_flange_pose"))
            solution = kin.inverse(ur_model, T, q)
            if solution is None:
                raise ValueError(f"Controller: initial_flange_pose {initial_flange_pose}"
                                 f" is unreachable for {model}")
            q = solution
        self.host = host
        self.model_name = model
        self.lock = threading.RLock()
        self.arm = Arm(ur_model, q, _vector(tcp_offset, "tcp_offset"), speed_factor, instant)
        self.registers = Registers()
        self._record = CommandRecord(record_path)
        self._faults = [parse_fault(spec) for spec in inject]
        self._script: ControlScript | None = None
        self._paused = False
        self._robot_mode = ROBOT_MODE_RUNNING
        self._safety_mode = SAFETY_NORMAL
        self._remote_control = remote_control
        self._refuse_next_start = False
        self._stall_until_s = 0.0
        self._slow_s = 0.0
        self._standard_do = 0
        self._configurable_do = 0
        self._tool_do = 0
        self._analog_out = [0.0, 0.0]
        self._start_s = time.monotonic()
        self._time_s = 0.0
        self._outputs: Mapping[str, object] = {}
        self._stopping = threading.Event()
        self._loop: threading.Thread | None = None
        self._rtde = RtdeServer(host, self)
        self._dashboard = DashboardServer(host, self)
        self._script_port = ScriptPort(host, self.run_program)
        self._listeners = (self._rtde.listener, self._dashboard.listener,
                           self._script_port.listener)
        with self.lock:
            self._publish()

    # --- lifetime ---------------------------------------------------------------------------

    def start(self) -> Controller:
        """Start the control loop and listen on 30004, 29999 and 30003; returns when listening."""
        with self.lock:
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
        self._record.close()

    def __enter__(self) -> Controller:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.stop()

    # --- public API -------------------------------------------------------------------------

    @property
    def commands(self) -> list[dict[str, Any]]:
        """A copy of the command record: one dict per motion or stop command, in order."""
        return self._record.entries()

    def inject(self, spec: str) -> None:
        """Inject a fault, `FAULT@WHEN` (`@now` implied); see faults.py for the names."""
        fault = parse_fault(spec)
        with self.lock:
            if fault.move_index is None:
                self._apply(fault)
            else:
                self._faults.append(fault)

    def set_remote_control(self, enabled: bool) -> None:
        with self.lock:
            self._remote_control = enabled

    def snapshot(self) -> ControllerSnapshot:
        with self.lock:
            arm = self.arm
            return ControllerSnapshot(
                q=tuple(arm.q.tolist()),
                flange_pose=tuple(arm.flange_pose.tolist()),
                tcp_pose=tuple(arm.tcp_pose.tolist()),
                tcp_offset=tuple(arm.tcp_offset.tolist()),
                robot_mode=self._robot_mode,
                safety_mode=self._safety_mode,
                runtime_state=self._runtime_state(),
                program_running=self._runtime_state() == RUNTIME_PLAYING,
                remote_control=self._remote_control,
                moving=arm.motion is not None,
                standard_digital_out=self._standard_do,
                tool_digital_out=self._tool_do,
                configurable_digital_out=self._configurable_do,
                payload_kg=arm.payload_kg,
                time_s=self._time_s,
            )

    # --- program control (script port, dashboard) -------------------------------------------

    def run_program(self, program: str) -> None:
        """Run a program received on 30003; a new program replaces the running one."""
        with self.lock:
            if "def rtde_control():" not in program:
                log.warning("script port: ignoring a program that is not ur_rtde's "
                            "rtde_control (%d bytes)", len(program))
                return
            refusal = self._start_refusal()
            if refusal:
                log.warning("script port: not starting rtde_control: %s", refusal)
                return
            if self._script is not None:
                self._script.stop("replaced by a new program on the script port")
            self._paused = False
            self._script = ControlScript(self.registers, self.arm, self._record,
                                         register_offsets(program), self._protective_stop,
                                         self._time_s)
            self._script.ack_delay_s = self._slow_s
            log.info("rtde_control program started")

    def _start_refusal(self) -> str:
        if not self._remote_control:
            return "the robot is in local control"
        if self._robot_mode != ROBOT_MODE_RUNNING:
            return f"robot mode is {self._robot_mode}, expected 7 (RUNNING)"
        if self._safety_mode != SAFETY_NORMAL:
            return f"safety mode is {self._safety_mode}, expected 1 (NORMAL)"
        return ""

    def program_name(self) -> str:
        return "<unnamed>" if self._script is None else "rtde_control"

    def stop_program(self, reason: str) -> None:
        with self.lock:
            if self._script is not None:
                self._script.stop(reason)
            self._paused = False

    def pause_program(self) -> bool:
        with self.lock:
            if self._runtime_state() != RUNTIME_PLAYING:
                return False
            self._paused = True
            self.arm.halt()
            return True

    def resume_program(self) -> bool:
        with self.lock:
            if self._runtime_state() != RUNTIME_PAUSED or self._safety_mode != SAFETY_NORMAL:
                return False
            self._paused = False
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
        self.arm.halt()

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
            self.arm.halt()
        elif fault.name == "drop-connection":
            for listener in self._listeners:
                listener.drop_clients()
        elif fault.name == "stall":
            self._stall_until_s = time.monotonic() + (fault.seconds or 0.0)
        elif fault.name == "stop-program":
            self.stop_program("stopped from the pendant")
        elif fault.name == "remote-control-off":
            self._remote_control = False
        elif fault.name == "refuse-start":
            self._refuse_next_start = True
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
            regs = self.registers
            for name, value in values.items():
                if name.startswith("input_int_register_"):
                    n = int(name.rsplit("_", 1)[1])
                    regs.in_int[n] = int(_number(value))
                    regs.in_int_written_s[n] = self._time_s
                elif name.startswith("input_double_register_"):
                    regs.in_double[int(name.rsplit("_", 1)[1])] = _number(value)
            self._standard_do = _masked(values, "standard_digital_output", self._standard_do)
            self._configurable_do = _masked(values, "configurable_digital_output",
                                            self._configurable_do)
            self._tool_do = _masked(values, "tool_digital_output", self._tool_do)
            if values.get("speed_slider_mask") == 1:
                self.arm.speed_slider = min(1.0, max(0.0, _number(values["speed_slider_fraction"])))
            analog_mask = values.get("standard_analog_output_mask", 0)
            for i in (0, 1):
                if isinstance(analog_mask, int) and analog_mask & (1 << i):
                    self._analog_out[i] = _number(values[f"standard_analog_output_{i}"])

    # --- the control loop -------------------------------------------------------------------

    def _run(self) -> None:
        next_s = last_s = time.monotonic()
        while not self._stopping.is_set():
            next_s += CYCLE_S
            delay_s = next_s - time.monotonic()
            if delay_s > 0:
                self._stopping.wait(delay_s)
            elif delay_s < -0.1:
                next_s = time.monotonic()  # fell far behind (machine busy): resync
            now_s = time.monotonic()
            with self.lock:
                try:
                    self._cycle(now_s - last_s, now_s - self._start_s)
                except Exception:
                    log.exception("control loop cycle failed")
            self._rtde.cycle_done()  # the cycle's RTDE package goes out now, as on a real UR
            last_s = now_s

    def _cycle(self, dt_s: float, time_s: float) -> None:
        self._time_s = time_s
        script = self._script
        if (script is not None and self._runtime_state() == RUNTIME_PLAYING
                and self._safety_mode == SAFETY_NORMAL):
            script.cycle(time_s)
        try:
            motion = self.arm.advance(dt_s)
        except UnreachableError as exc:
            self._protective_stop(str(exc))
            motion = None
        if motion is not None:
            self._fire_move_faults(motion.index, motion.fraction)
        self._publish()

    def _fire_move_faults(self, index: int, fraction: float) -> None:
        due = [f for f in self._faults if f.move_index == index and fraction >= f.fraction]
        for fault in due:
            self._faults.remove(fault)
            self._apply(fault)

    def _runtime_state(self) -> int:
        if self._script is None or not self._script.running:
            return RUNTIME_STOPPED
        return RUNTIME_PAUSED if self._paused else RUNTIME_PLAYING

    def _publish(self) -> None:
        """Build every output variable's value for the RTDE senders (replaced, never mutated)."""
        arm = self.arm
        q = tuple(arm.q.tolist())
        qd = tuple(arm.qd.tolist())
        tcp_pose = tuple(arm.tcp_pose.tolist())
        tcp_speed = tuple(arm.tcp_speed.tolist())
        zeros6 = (0.0,) * 6
        powered = self._robot_mode >= ROBOT_MODE_IDLE
        runtime_state = self._runtime_state()
        out: dict[str, object] = {name: zeros6 for name, t in OUTPUT_TYPES.items()
                                  if t == "VECTOR6D"}
        out.update(
            timestamp=self._time_s,
            target_q=q, actual_q=q, target_qd=qd, actual_qd=qd,
            actual_TCP_pose=tcp_pose, target_TCP_pose=tcp_pose,
            actual_TCP_speed=tcp_speed, target_TCP_speed=tcp_speed,
            joint_temperatures=(30.0,) * 6,
            actual_joint_voltage=(48.0,) * 6 if powered else zeros6,
            actual_execution_time=0.4,
            robot_mode=self._robot_mode,
            joint_mode=(_JOINT_MODE_RUNNING if powered else _JOINT_MODE_POWER_OFF,) * 6,
            safety_mode=self._safety_mode,
            actual_tool_accelerometer=(0.0, 0.0, 0.0),
            speed_scaling=1.0,
            target_speed_fraction=arm.speed_slider,
            actual_momentum=0.0,
            actual_main_voltage=48.0,
            actual_robot_voltage=48.0 if powered else 0.0,
            actual_robot_current=0.5 if powered else 0.0,
            actual_digital_input_bits=0,
            actual_digital_output_bits=(self._standard_do | self._configurable_do << 8
                                        | self._tool_do << 16),
            runtime_state=runtime_state,
            standard_analog_input0=0.0, standard_analog_input1=0.0,
            standard_analog_output0=self._analog_out[0],
            standard_analog_output1=self._analog_out[1],
            robot_status_bits=int(powered) | int(runtime_state == RUNTIME_PLAYING) << 1,
            safety_status_bits=_SAFETY_BITS[self._safety_mode],
            payload=arm.payload_kg,
            payload_cog=tuple(arm.payload_cog_m.tolist()),
            output_bit_registers0_to_31=0,
            output_bit_registers32_to_63=0,
        )
        regs = self.registers
        for n in range(48):
            out[f"output_int_register_{n}"] = regs.out_int[n]
            out[f"output_double_register_{n}"] = regs.out_double[n]
        self._outputs = out


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
