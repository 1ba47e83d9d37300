"""The values of every RTDE output field, built once per control cycle from the controller state.

Fields nothing in the simulation drives are constant and plausible (zeros, 48 V supplies, 30 degC
joints); everything the simulation does drive is real: joints, poses and speeds (target and
actual), elbow, modes and status bits, digital and analog IO, every register as last written
(input registers read back included), payload, TCP offset.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from mocks.ur_controller.arm import Arm
from mocks.ur_controller.program import Registers

ROBOT_MODE_IDLE = 5
RUNTIME_PLAYING = 2
_JOINT_MODE_RUNNING = 253
_JOINT_MODE_POWER_OFF = 239
_TOOL_MODE_RUNNING = 253
_TOOL_OUTPUT_VOLTAGE_V = 24
# safety_status_bits per safety mode: 0 normal, 2 protective stopped, 4 safeguard stopped,
# 6 robot e-stop, 7 emergency stopped, 10 stopped due to safety.
_SAFETY_BITS = {1: 1 << 0, 3: (1 << 2) | (1 << 10), 5: (1 << 4) | (1 << 10),
                7: (1 << 6) | (1 << 7) | (1 << 10)}
# Assumed scale of joint_position_deviation_ratio: the deviation (rad) that makes it 1.0.
JOINT_DEVIATION_LIMIT_RAD = 0.1
_ZERO = {"BOOL": False, "UINT8": 0, "INT32": 0, "UINT32": 0, "UINT64": 0, "DOUBLE": 0.0,
         "VECTOR3D": (0.0,) * 3, "VECTOR6D": (0.0,) * 6, "VECTOR6INT32": (0,) * 6,
         "VECTOR6UINT32": (0,) * 6}


@dataclass(frozen=True)
class Modes:
    robot_mode: int  # 7 RUNNING, 5 IDLE, 3 POWER_OFF
    safety_mode: int  # 1 NORMAL, 3 PROTECTIVE_STOP, 5 SAFEGUARD_STOP, 7 ROBOT_EMERGENCY_STOP
    runtime_state: int  # 1 STOPPED, 2 PLAYING, 3 PAUSING, 4 PAUSED


@dataclass(frozen=True)
class Io:
    standard_do: int  # bits 0-7
    configurable_do: int  # bits 0-7
    tool_do: int  # bits 0-1
    digital_inputs: int  # actual_digital_input_bits
    analog_out: tuple[float, float]  # ratio 0..1 as written
    analog_io_types: int  # bits 0-1 inputs, 2-3 outputs: 0 current, 1 voltage


class OutputTable:
    """Builds the output dict for one controller's served fields (`types`: name -> UR type)."""

    def __init__(self, types: Mapping[str, str]):
        self._defaults: dict[str, object] = {name: _ZERO[t] for name, t in types.items()}
        self._defaults.update(
            joint_temperatures=(30.0,) * 6, actual_execution_time=0.4, speed_scaling=1.0,
            actual_main_voltage=48.0, tool_mode=_TOOL_MODE_RUNNING,
            tool_output_voltage=_TOOL_OUTPUT_VOLTAGE_V, tool_temperature=30.0,
        )
        self._served = set(types)
        self._unserved: list[str] | None = None  # of the fields `build` computes

    def build(self, time_s: float, arm: Arm, modes: Modes, io: Io,
              registers: Registers) -> dict[str, object]:
        """Every served field's value at controller time `time_s` (a new dict each call)."""
        out = dict(self._defaults)
        powered = modes.robot_mode >= ROBOT_MODE_IDLE
        q, actual_q = tuple(arm.q.tolist()), tuple(arm.actual_q.tolist())
        deviation = max(abs(a - b) for a, b in zip(q, actual_q, strict=True))
        state = dict(
            timestamp=time_s,
            target_q=q, actual_q=actual_q,
            target_qd=tuple(arm.qd.tolist()), actual_qd=tuple(arm.actual_qd.tolist()),
            target_TCP_pose=tuple(arm.tcp_pose.tolist()),
            actual_TCP_pose=tuple(arm.actual_tcp_pose.tolist()),
            target_TCP_speed=tuple(arm.tcp_speed.tolist()),
            actual_TCP_speed=tuple(arm.tcp_speed.tolist()),
            elbow_position=tuple(arm.elbow_position.tolist()),
            elbow_velocity=tuple(arm.elbow_velocity.tolist()),
            actual_joint_voltage=(48.0,) * 6 if powered else (0.0,) * 6,
            robot_mode=modes.robot_mode,
            joint_mode=(_JOINT_MODE_RUNNING if powered else _JOINT_MODE_POWER_OFF,) * 6,
            safety_mode=modes.safety_mode,
            safety_status=modes.safety_mode,  # same numbering for the modes simulated
            target_speed_fraction=arm.speed_slider,
            actual_robot_voltage=48.0 if powered else 0.0,
            actual_robot_current=0.5 if powered else 0.0,
            actual_digital_input_bits=io.digital_inputs,
            actual_digital_output_bits=(io.standard_do | io.configurable_do << 8
                                        | io.tool_do << 16),
            runtime_state=modes.runtime_state,
            robot_status_bits=int(powered) | int(modes.runtime_state == RUNTIME_PLAYING) << 1,
            safety_status_bits=_SAFETY_BITS[modes.safety_mode],
            analog_io_types=io.analog_io_types,
            standard_analog_output0=io.analog_out[0],
            standard_analog_output1=io.analog_out[1],
            payload=arm.payload_kg,
            payload_cog=tuple(arm.payload_cog_m.tolist()),
            payload_inertia=tuple(arm.payload_inertia.tolist()),
            tcp_offset=tuple(arm.tcp_offset.tolist()),
            joint_position_deviation_ratio=deviation / JOINT_DEVIATION_LIMIT_RAD,
        )
        # Only served fields: a CB3 has no safety_status or joint_position_deviation_ratio.
        if self._unserved is None:
            self._unserved = [name for name in state if name not in self._served]
        for name in self._unserved:
            del state[name]
        out.update(state)
        _registers(out, registers)
        return out


class _RegisterNames:
    """Output field names of every register, in register order (built once, not per cycle)."""

    def __init__(self) -> None:
        self.out_int = [f"output_int_register_{n}" for n in range(48)]
        self.out_double = [f"output_double_register_{n}" for n in range(48)]
        self.in_int = [f"input_int_register_{n}" for n in range(48)]
        self.in_double = [f"input_double_register_{n}" for n in range(48)]
        self.out_bits = [f"output_bit_register_{n}" for n in range(64, 128)]
        self.in_bits = [f"input_bit_register_{n}" for n in range(64, 128)]


_NAMES = _RegisterNames()


def _registers(out: dict[str, object], regs: Registers) -> None:
    out.update(zip(_NAMES.out_int, regs.out_int, strict=True))
    out.update(zip(_NAMES.out_double, regs.out_double, strict=True))
    out.update(zip(_NAMES.in_int, regs.in_int, strict=True))
    out.update(zip(_NAMES.in_double, regs.in_double, strict=True))
    out.update(zip(_NAMES.out_bits, regs.out_bits[64:], strict=True))
    out.update(zip(_NAMES.in_bits, regs.in_bits[64:], strict=True))
    out["output_bit_registers0_to_31"] = _pack(regs.out_bits[0:32])
    out["output_bit_registers32_to_63"] = _pack(regs.out_bits[32:64])
    out["input_bit_registers0_to_31"] = _pack(regs.in_bits[0:32])
    out["input_bit_registers32_to_63"] = _pack(regs.in_bits[32:64])


def _pack(bits: list[bool]) -> int:
    """32 bits, bit i first, as the guide's UINT32 bit fields hold them."""
    return int("".join("1" if bit else "0" for bit in reversed(bits)), 2) if any(bits) else 0
