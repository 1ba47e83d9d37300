"""Grippers: one module per kind behind ``gripper.port.Gripper``; ``connect_gripper`` picks the
kind the config names (``robot.gripper.type``, read by ``config/gripper.py``)."""

from __future__ import annotations

from collections.abc import Callable

from handeye_pick.config.gripper import AnyGripperConfig, GripperConfig
from handeye_pick.gripper.port import GraspState, Gripper
from handeye_pick.robot.port import RobotArm

__all__ = ["GraspState", "Gripper", "connect_gripper"]


def connect_gripper(
    gripper: AnyGripperConfig | None, host: str, arm: RobotArm, say: Callable[[str], None]
) -> Gripper | None:
    """The configured gripper (``robot.gripper``) on the robot at ``host``, connected (None
    when the config has none); ``say`` hears what the operator should know (an activation that
    moves the fingers)."""
    if gripper is None:
        return None
    if isinstance(gripper, GripperConfig):
        from handeye_pick.gripper.digital import DigitalOutputGripper

        return DigitalOutputGripper(gripper, arm)
    from handeye_pick.gripper.robotiq import Robotiq2F

    return Robotiq2F(host, gripper, say)
