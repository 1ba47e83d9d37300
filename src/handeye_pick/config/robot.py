"""The ``robot`` section: the controller's address, the TCP offset the pendant must have, the
watchdog, the gripper (``config/gripper.py``), the empty tool's payload (``payload.py``) and the
arm's model (``arm.py``)."""

from __future__ import annotations

from handeye_pick.config.arm import read_arm_model
from handeye_pick.config.gripper import read_gripper
from handeye_pick.config.payload import read_tool_payload
from handeye_pick.config.poses import pose_vector
from handeye_pick.config.reader import Fields, Number
from handeye_pick.config.schema import MAX_TCP_OFFSET_M, RobotConfig

_NUMBERS = {
    "tcp_offset_tolerance_mm": Number(
        "mm", above=0.0, maximum=20.0, default=RobotConfig.tcp_offset_tolerance_mm
    ),
    "tcp_offset_tolerance_deg": Number(
        "deg", above=0.0, maximum=10.0, default=RobotConfig.tcp_offset_tolerance_deg
    ),
    "watchdog_s": Number("s", minimum=0.05, maximum=2.0, default=RobotConfig.watchdog_s),
}
_KEYS = ("host", "tcp_offset", "gripper", "tool_payload", "model", "links", *_NUMBERS)


def read_robot(top: Fields) -> RobotConfig:
    """``robot``; ``tcp_offset`` is ``T_flange_tcp`` as a UR pose vector (m, rad)."""
    robot = top.section("robot", _KEYS)
    return RobotConfig(
        host=robot.string("host"),
        T_flange_tcp=pose_vector(robot, "tcp_offset", MAX_TCP_OFFSET_M),
        tcp_offset_tolerance_mm=robot.number("tcp_offset_tolerance_mm", _NUMBERS),
        tcp_offset_tolerance_deg=robot.number("tcp_offset_tolerance_deg", _NUMBERS),
        gripper=read_gripper(robot) if robot.has("gripper") else None,
        watchdog_s=robot.number("watchdog_s", _NUMBERS),
        tool_payload=read_tool_payload(robot) if robot.has("tool_payload") else None,
        model=read_arm_model(robot),
    )
