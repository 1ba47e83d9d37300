"""The RTDE fields UR documents for PolyScope 5.15, written down for the tests from UR's RTDE guide
and the field table of UR's C++ client library (src/rtde/data_package.cpp), independently of the
simulator's own table."""

from __future__ import annotations


def _registers(direction: str) -> dict[str, str]:
    names = {f"{direction}_bit_registers0_to_31": "UINT32",
             f"{direction}_bit_registers32_to_63": "UINT32"}
    names.update({f"{direction}_bit_register_{n}": "BOOL" for n in range(64, 128)})
    names.update({f"{direction}_int_register_{n}": "INT32" for n in range(48)})
    names.update({f"{direction}_double_register_{n}": "DOUBLE" for n in range(48)})
    return names


_OUTPUT_SPEC = {
    "DOUBLE": "timestamp actual_execution_time speed_scaling target_speed_fraction "
              "actual_momentum actual_main_voltage actual_robot_voltage actual_robot_current "
              "standard_analog_input0 standard_analog_input1 standard_analog_output0 "
              "standard_analog_output1 io_current euromap67_24V_voltage euromap67_24V_current "
              "tool_analog_input0 tool_analog_input1 tool_output_current tool_temperature "
              "tcp_force_scalar payload joint_position_deviation_ratio collision_detection_ratio",
    "VECTOR6D": "target_q target_qd target_qdd target_current target_moment actual_q actual_qd "
                "actual_current actual_current_window joint_control_output actual_TCP_pose "
                "actual_TCP_speed actual_TCP_force target_TCP_pose target_TCP_speed "
                "joint_temperatures actual_joint_voltage payload_inertia ft_raw_wrench tcp_offset",
    "VECTOR3D": "actual_tool_accelerometer elbow_position elbow_velocity payload_cog",
    "VECTOR6INT32": "joint_mode",
    "INT32": "robot_mode safety_mode safety_status tool_output_voltage time_scale_source",
    "UINT32": "runtime_state robot_status_bits safety_status_bits analog_io_types "
              "euromap67_input_bits euromap67_output_bits tool_mode tool_analog_input_types "
              "script_control_line",
    "UINT64": "actual_digital_input_bits actual_digital_output_bits",
    "UINT8": "tool_output_mode tool_digital_output0_mode tool_digital_output1_mode",
}

OUTPUTS_5_15: dict[str, str] = {
    name: type_ for type_, names in _OUTPUT_SPEC.items() for name in names.split()
}
OUTPUTS_5_15.update(_registers("output"))
OUTPUTS_5_15.update(_registers("input"))  # input registers read back

INPUTS_5_15: dict[str, str] = {
    "speed_slider_mask": "UINT32", "speed_slider_fraction": "DOUBLE",
    "standard_digital_output_mask": "UINT8", "standard_digital_output": "UINT8",
    "configurable_digital_output_mask": "UINT8", "configurable_digital_output": "UINT8",
    "standard_analog_output_mask": "UINT8", "standard_analog_output_type": "UINT8",
    "standard_analog_output_0": "DOUBLE", "standard_analog_output_1": "DOUBLE",
    "external_force_torque": "VECTOR6D",
    **_registers("input"),
}

# The fields a CB3 never has: the e-Series' own hardware and monitors.
E_SERIES_ONLY = ("ft_raw_wrench", "tool_output_mode", "tool_digital_output0_mode",
                 "tool_digital_output1_mode", "joint_position_deviation_ratio",
                 "collision_detection_ratio", "time_scale_source", "actual_current_window")

# UR's record.py example recipe (RTDE_Python_Client_Library, examples/record_configuration.xml,
# the fields it asks for) with the types that file states.
RECORD_PY_RECIPE = {
    "timestamp": "DOUBLE", "target_q": "VECTOR6D", "target_qd": "VECTOR6D",
    "target_qdd": "VECTOR6D", "target_current": "VECTOR6D", "target_moment": "VECTOR6D",
    "actual_q": "VECTOR6D", "actual_qd": "VECTOR6D", "actual_current": "VECTOR6D",
    "joint_control_output": "VECTOR6D", "actual_TCP_pose": "VECTOR6D",
    "actual_TCP_speed": "VECTOR6D", "actual_TCP_force": "VECTOR6D", "target_TCP_pose": "VECTOR6D",
    "target_TCP_speed": "VECTOR6D", "actual_digital_input_bits": "UINT64",
    "joint_temperatures": "VECTOR6D", "actual_execution_time": "DOUBLE", "robot_mode": "INT32",
    "joint_mode": "VECTOR6INT32", "safety_status": "INT32",
    "actual_tool_accelerometer": "VECTOR3D", "speed_scaling": "DOUBLE",
    "target_speed_fraction": "DOUBLE", "actual_momentum": "DOUBLE",
    "actual_main_voltage": "DOUBLE", "actual_robot_voltage": "DOUBLE",
    "actual_robot_current": "DOUBLE", "actual_joint_voltage": "VECTOR6D",
    "actual_digital_output_bits": "UINT64", "runtime_state": "UINT32",
    "joint_position_deviation_ratio": "DOUBLE",
}
