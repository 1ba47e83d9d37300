"""The async motion commands the ur_rtde adapter sends, and how far one has come.

Frames and units as in robot/port.py: 4x4 float64 transforms in metres; UR pose vectors (m and
rad, base frame); speeds m/s (rad/s for joints).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from handeye_pick.geometry import Transform, rotation_angle_between


@dataclass(frozen=True)
class MoveKind:
    """One async motion command as the child sends it: moveL (pose, m/s, m/s^2), moveJ
    (joints, rad/s, rad/s^2) or a moveL path (waypoint rows, see ``move_path``)."""

    name: str
    operation: str
    args: tuple[object, ...]  # the child operation's arguments
    description: str  # the target and its speeds, for the log and a refusal


def single(name: str, operation: str, target: list[float], speed: float, accel: float) -> MoveKind:
    """A single moveL or moveJ to ``target`` at ``speed`` and ``accel``."""
    return MoveKind(
        name, operation, (target, speed, accel), f"{fmt_pose(target)} v={speed:.3f} a={accel:.3f}"
    )


def fmt_pose(pose: list[float]) -> str:
    """A UR pose vector (or joints) for the log: four decimals."""
    return "[" + ", ".join(f"{v:.4f}" for v in pose) + "]"


def motion_fraction(T_start: Transform, T_now: Transform, T_target: Transform) -> float:
    """Fraction of a linear move done, 0..1, from the distance left (angle for pure rotations)."""
    total = float(np.linalg.norm(T_target[:3, 3] - T_start[:3, 3]))
    if total > 1e-3:
        left = float(np.linalg.norm(T_target[:3, 3] - T_now[:3, 3]))
    else:
        total = rotation_angle_between(T_start[:3, :3], T_target[:3, :3])
        left = rotation_angle_between(T_now[:3, :3], T_target[:3, :3])
        if total < 1e-6:
            return 1.0
    return min(1.0, max(0.0, 1.0 - left / total))
