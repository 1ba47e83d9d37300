"""Approach, grasp and retreat TCP targets for one detected object.

Frames and units: every pose is a 4x4 in metres in the robot base frame; targets are
``T_base_tcp``. The approach and retreat points are the grasp pose moved back along its own tool
z axis (the tool points into the object along +z), so the last move onto the object and the
first move off it are straight along the tool axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from handeye_pick.config.schema import GraspConfig
from handeye_pick.geometry import Transform, make_transform

_DOWN = np.array([0.0, 0.0, -1.0])


@dataclass(frozen=True)
class PickTargets:
    """The three TCP targets of a pick, ``T_base_tcp`` in metres."""

    approach: Transform
    grasp: Transform
    retreat: Transform


def _cross(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cross product of two 3-vectors; np.cross costs ~40 us a call, this ~3 us."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def tool_down_keeping_yaw(R_base_tcp: NDArray[np.float64]) -> NDArray[np.float64]:
    """A 3x3 rotation with tool z straight down (base -z) and the yaw of ``R_base_tcp``.

    The current tool is tilted to straight down by the smallest rotation, which keeps its yaw (its
    turn about the vertical). A tool already pointing down keeps its rotation exactly; a tool
    pointing (almost) straight up is turned over about its own x axis.
    """
    x_now, z_now = R_base_tcp[:, 0], R_base_tcp[:, 2]
    cos = float(z_now @ _DOWN)
    if cos > -1.0 + 1e-9:
        # Rodrigues for the smallest rotation taking z_now to down, applied to x_now
        # (closed form: this runs on every pick, scipy's Rotation costs ~0.1 ms a call).
        v = _cross(z_now, _DOWN)
        vx = _cross(v, x_now)
        x = x_now + vx + _cross(v, vx) / (1.0 + cos)
    else:
        x = x_now.copy()
    # Rebuild from the horizontal x so the tool z is exactly base -z (no rounding tilt).
    x[2] = 0.0
    x /= np.linalg.norm(x)
    R = np.empty((3, 3))
    R[:, 0] = x
    R[:, 1] = _cross(_DOWN, x)
    R[:, 2] = _DOWN
    return R


def backed_off(T_base_tcp: Transform, distance_m: float) -> Transform:
    """``T_base_tcp`` moved ``distance_m`` back along its own tool z axis (rotation unchanged)."""
    out: Transform = T_base_tcp.copy()
    out[:3, 3] -= distance_m * T_base_tcp[:3, 2]
    return out


def plan_targets(
    T_base_obj: Transform,
    T_base_tcp_now: Transform,
    grasp: GraspConfig,
    position_only: bool,
) -> PickTargets:
    """Approach, grasp and retreat ``T_base_tcp`` targets (m) for an object at ``T_base_obj``.

    With an orientation: ``T_base_tcp_grasp = T_base_obj @ grasp.T_obj_tcp``.
    Position only (the object's rotation means nothing): the TCP goes to the object's position
    with the tool pointing straight down and the current TCP yaw kept; ``T_obj_tcp`` is not used.
    """
    if position_only:
        T_grasp = make_transform(tool_down_keeping_yaw(T_base_tcp_now[:3, :3]), T_base_obj[:3, 3])
    else:
        T_grasp = T_base_obj @ grasp.T_obj_tcp
    return PickTargets(
        approach=backed_off(T_grasp, grasp.approach_mm / 1000.0),
        grasp=T_grasp,
        retreat=backed_off(T_grasp, grasp.retreat_mm / 1000.0),
    )
