"""RTDE field tables: every name UR documents for PolyScope 5.15 (and what a CB3 3.15 has), typed.

Sources: UR's RTDE guide (docs.universal-robots.com, "Real-Time Data Exchange (RTDE) Guide", field
tables with the software version each field appeared in) and the field -> type table of UR's C++
client library (Universal_Robots_Client_Library, src/rtde/data_package.cpp). Where the guide's
first version of a field was not at hand, the version below is the one UR's client libraries gate
on (ur_rtde's receive recipe, the client library's PolyScope compatibility table) and is marked
"assumed" in README.md.

A version is (major, minor, bugfix). A field is served when the controller's version is at least
its minimum for the controller's line: CB3 (3.x) or e-Series (5.x; PolyScope X 10.x serves every
e-Series field). `None` means the line never has the field.
"""

from __future__ import annotations

from dataclasses import dataclass

Version = tuple[int, int, int]

_ALWAYS: Version = (0, 0, 0)


@dataclass(frozen=True)
class Field:
    """One RTDE variable: its UR type and the first CB3 / e-Series versions that have it."""

    name: str
    type: str
    cb3: Version | None = _ALWAYS
    e_series: Version | None = _ALWAYS

    def served_by(self, version: Version) -> bool:
        first = self.cb3 if version[0] < 5 else self.e_series
        if first is None:
            return False
        return version[0] >= 10 or version >= first


def _fields(type_: str, names: str, cb3: Version | None = _ALWAYS,
            e_series: Version | None = _ALWAYS) -> list[Field]:
    return [Field(name, type_, cb3, e_series) for name in names.split()]


def _numbered(pattern: str, type_: str, numbers: range, cb3: Version | None = _ALWAYS,
              e_series: Version | None = _ALWAYS) -> list[Field]:
    return [Field(pattern.format(n), type_, cb3, e_series) for n in numbers]


# Registers 24-47 and the single bits 64-127 came with PolyScope 3.9 / 5.3.
_UPPER: dict[str, Version] = {"cb3": (3, 9, 0), "e_series": (5, 3, 0)}


def _register_fields(prefix: str) -> list[Field]:
    """`{prefix}_int/double_register_0..47` and the bit registers, as the guide lists them."""
    return [
        *_fields("UINT32", f"{prefix}_bit_registers0_to_31 {prefix}_bit_registers32_to_63"),
        *_numbered(prefix + "_bit_register_{}", "BOOL", range(64, 128), **_UPPER),
        *_numbered(prefix + "_int_register_{}", "INT32", range(24)),
        *_numbered(prefix + "_int_register_{}", "INT32", range(24, 48), **_UPPER),
        *_numbered(prefix + "_double_register_{}", "DOUBLE", range(24)),
        *_numbered(prefix + "_double_register_{}", "DOUBLE", range(24, 48), **_UPPER),
    ]


OUTPUTS: tuple[Field, ...] = (
    *_fields("DOUBLE", "timestamp"),
    *_fields("VECTOR6D", "target_q target_qd target_qdd target_current target_moment actual_q "
                         "actual_qd actual_current"),
    *_fields("VECTOR6D", "actual_current_window", cb3=None),
    *_fields("VECTOR6D", "joint_control_output actual_TCP_pose actual_TCP_speed actual_TCP_force "
                         "target_TCP_pose target_TCP_speed"),
    *_fields("UINT64", "actual_digital_input_bits"),
    *_fields("VECTOR6D", "joint_temperatures"),
    *_fields("DOUBLE", "actual_execution_time"),
    *_fields("INT32", "robot_mode"),
    *_fields("VECTOR6INT32", "joint_mode"),
    *_fields("INT32", "safety_mode"),
    *_fields("INT32", "safety_status", cb3=(3, 10, 0), e_series=(5, 4, 0)),
    *_fields("VECTOR3D", "actual_tool_accelerometer"),
    *_fields("DOUBLE", "speed_scaling target_speed_fraction actual_momentum actual_main_voltage "
                       "actual_robot_voltage actual_robot_current"),
    *_fields("VECTOR6D", "actual_joint_voltage"),
    *_fields("UINT64", "actual_digital_output_bits"),
    *_fields("UINT32", "runtime_state"),
    *_fields("VECTOR3D", "elbow_position elbow_velocity", cb3=(3, 5, 0), e_series=(5, 0, 0)),
    *_fields("UINT32", "robot_status_bits safety_status_bits analog_io_types"),
    *_fields("DOUBLE", "standard_analog_input0 standard_analog_input1 standard_analog_output0 "
                       "standard_analog_output1 io_current"),
    *_fields("UINT32", "euromap67_input_bits euromap67_output_bits"),
    *_fields("DOUBLE", "euromap67_24V_voltage euromap67_24V_current"),
    *_fields("UINT32", "tool_mode tool_analog_input_types"),
    *_fields("DOUBLE", "tool_analog_input0 tool_analog_input1"),
    *_fields("INT32", "tool_output_voltage"),
    *_fields("DOUBLE", "tool_output_current tool_temperature tcp_force_scalar"),
    *_register_fields("output"),
    *_register_fields("input"),  # input registers read back
    *_fields("UINT8", "tool_output_mode tool_digital_output0_mode tool_digital_output1_mode",
             cb3=None, e_series=(5, 2, 0)),
    *_fields("DOUBLE", "payload", cb3=(3, 11, 0), e_series=(5, 5, 1)),
    *_fields("VECTOR3D", "payload_cog", cb3=(3, 11, 0), e_series=(5, 5, 1)),
    *_fields("VECTOR6D", "payload_inertia", cb3=(3, 15, 0), e_series=(5, 11, 0)),
    *_fields("UINT32", "script_control_line", cb3=(3, 14, 0), e_series=(5, 9, 0)),
    *_fields("VECTOR6D", "ft_raw_wrench", cb3=None, e_series=(5, 9, 0)),
    *_fields("DOUBLE", "joint_position_deviation_ratio collision_detection_ratio", cb3=None,
             e_series=(5, 8, 0)),
    *_fields("INT32", "time_scale_source", cb3=None, e_series=(5, 8, 0)),
    *_fields("VECTOR6D", "tcp_offset", cb3=(3, 12, 3), e_series=(5, 5, 1)),
)

INPUTS: tuple[Field, ...] = (
    *_fields("UINT32", "speed_slider_mask"),
    *_fields("DOUBLE", "speed_slider_fraction"),
    *_fields("UINT8", "standard_digital_output_mask standard_digital_output "
                      "configurable_digital_output_mask configurable_digital_output "
                      "tool_digital_output_mask tool_digital_output "
                      "standard_analog_output_mask standard_analog_output_type"),
    *_fields("DOUBLE", "standard_analog_output_0 standard_analog_output_1"),
    *_register_fields("input"),
    *_fields("VECTOR6D", "external_force_torque", cb3=(3, 3, 0), e_series=(5, 0, 0)),
)


def types_for(fields: tuple[Field, ...], version: Version) -> dict[str, str]:
    """Name -> UR type of every field a controller at `version` serves."""
    return {f.name: f.type for f in fields if f.served_by(version)}
