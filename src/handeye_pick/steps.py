"""The steps of a sequence: moveL and moveJ targets and gripper actions, in the order they run.

Frames and units: ``T_base_tcp`` float64 4x4 in metres in the robot base frame, joints radians.
"""

from __future__ import annotations

from dataclasses import dataclass

from handeye_pick.geometry import Transform


@dataclass(frozen=True)
class Move:
    """A moveL of the TCP to ``T_base_tcp``.

    ``slow`` moves run at the grasp speed (onto the object or the place). ``fixed`` targets come
    from the config (place poses, named poses): the controller's verdict on them may be reused
    for the rest of the session.
    """

    name: str
    T_base_tcp: Transform
    slow: bool = False
    fixed: bool = False
    blend_m: float = 0.0  # the corner's radius at this target (m, cell/blend.py); 0: a stop


@dataclass(frozen=True)
class JointMove:
    """A moveJ to the joint positions ``q_rad`` (rad) of a named pose from the config."""

    name: str
    q_rad: tuple[float, ...]


@dataclass(frozen=True)
class Grip:
    """Work the gripper: ``close`` grasps (then confirms), otherwise releases."""

    close: bool

    @property
    def name(self) -> str:
        return "gripper close" if self.close else "gripper open"


Step = Move | JointMove | Grip
