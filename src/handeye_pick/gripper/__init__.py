"""Grippers: one module per kind behind ``gripper.port.Gripper``; ``connect_gripper`` picks the
kind the config names (``robot.gripper.type``)."""

from __future__ import annotations

from collections.abc import Callable

from handeye_pick.config.schema import CellConfig, GripperConfig
from handeye_pick.gripper.port import GraspState, Gripper
from handeye_pick.robot.port import RobotArm

__all__ = ["GraspState", "Gripper", "connect_gripper"]


def connect_gripper(
    config: CellConfig, arm: RobotArm, say: Callable[[str], None]
) -> Gripper | None:
    """The configured gripper, connected (None when the config has none); ``say`` hears what
    the operator should know (an activation that moves the fingers)."""
    gripper = config.robot.gripper
    if gripper is None:
        return None
    if isinstance(gripper, GripperConfig):
        from handeye_pick.gripper.digital import DigitalOutputGripper

        return DigitalOutputGripper(gripper, arm)
    from handeye_pick.gripper.robotiq import Robotiq2F

    return Robotiq2F(config.robot.host, gripper, say)
