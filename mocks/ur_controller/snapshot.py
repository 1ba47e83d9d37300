"""ControllerSnapshot: the simulated controller's state at one instant, as the Python API, the
admin channel and the dashboard server read it.

Its own module so that those readers depend on this value, not on the controller itself.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ControllerSnapshot:
    """The controller's state at one instant (units: rad, m, kg, s)."""

    q: tuple[float, ...]  # target joints
    flange_pose: tuple[float, ...]  # target
    tcp_pose: tuple[float, ...]  # target, includes tcp_offset
    actual_tcp_pose: tuple[float, ...]  # as RTDE reports it (== tcp_pose without tracking)
    tcp_offset: tuple[float, ...]
    robot_mode: int  # 7 RUNNING
    safety_mode: int  # 1 NORMAL, 3 PROTECTIVE_STOP, 5 SAFEGUARD_STOP, 7 ROBOT_EMERGENCY_STOP
    runtime_state: int  # 2 PLAYING, 1 STOPPED, 4 PAUSED
    program_running: bool
    remote_control: bool
    moving: bool
    steady: bool  # URScript is_steady()
    standard_digital_out: int
    tool_digital_out: int
    configurable_digital_out: int
    payload_kg: float
    payload_cog: tuple[float, ...]  # m, tool flange frame
    digital_inputs: int  # actual_digital_input_bits
    gripper_position: int  # Robotiq POS, 0 open .. 255 closed
    gripper_object: int  # Robotiq OBJ
    part_present: bool  # the scripted part is between the fingers / at the gripper
    time_s: float  # controller time
    profile: str
