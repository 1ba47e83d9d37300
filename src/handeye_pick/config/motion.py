"""How and where the arm may move: the ``motion`` section (moveL and moveJ speeds, the stop, the
move timeout) and the ``workspace`` section (a box in the base frame and a tilt limit).

``safety.py`` enforces both before every move; here they are only read and checked against the
caps in ``limits.py``.
"""

from __future__ import annotations

import numpy as np

from handeye_pick.config.reader import Fields, Number
from handeye_pick.config.schema import (
    MAX_BLEND_MM,
    MAX_WORKSPACE_MM,
    MIN_WORKSPACE_EXTENT_MM,
    MotionConfig,
    WorkspaceConfig,
)
from handeye_pick.limits import (
    MAX_ACCEL_MPS2,
    MAX_GRASP_SPEED_MPS,
    MAX_JOINT_ACCEL_RPS2,
    MAX_JOINT_SPEED_RPS,
    MAX_SPEED_MPS,
    stop_decel_problem,
)

_MOTION_NUMBERS = {
    "speed_mps": Number("m/s", above=0.0, maximum=MAX_SPEED_MPS),
    "accel_mps2": Number("m/s^2", above=0.0, maximum=MAX_ACCEL_MPS2),
    "grasp_speed_mps": Number("m/s", above=0.0, maximum=MAX_GRASP_SPEED_MPS),
    # No cap of its own: stop_decel_problem bounds it against accel_mps2 and ur_rtde's limit.
    "stop_decel_mps2": Number("m/s^2", above=0.0, default=MotionConfig.stop_decel_mps2),
    "timeout_margin_s": Number(
        "s", above=0.0, maximum=120.0, default=MotionConfig.timeout_margin_s
    ),
    "joint_speed_rps": Number(
        "rad/s", above=0.0, maximum=MAX_JOINT_SPEED_RPS, default=MotionConfig.joint_speed_rps
    ),
    "joint_accel_rps2": Number(
        "rad/s^2", above=0.0, maximum=MAX_JOINT_ACCEL_RPS2, default=MotionConfig.joint_accel_rps2
    ),
    "blend_mm": Number("mm", minimum=0.0, maximum=MAX_BLEND_MM, default=MotionConfig.blend_mm),
}
_WORKSPACE_NUMBERS = {"max_tilt_deg": Number("deg", minimum=0.0, maximum=180.0)}


def read_motion(top: Fields) -> MotionConfig:
    """``motion``; the grasp move may not be faster than the travel moves, and the stop must
    brake at least as hard as a move accelerates."""
    motion = top.section("motion", (*_MOTION_NUMBERS, "blend_always"))
    speed = motion.number("speed_mps", _MOTION_NUMBERS)
    grasp_speed = motion.number("grasp_speed_mps", _MOTION_NUMBERS)
    if grasp_speed > speed:
        motion.fail(
            "grasp_speed_mps",
            f"the grasp move must not be faster than motion.speed_mps ({speed:g} m/s), "
            f"got {grasp_speed:g} m/s",
        )
    accel = motion.number("accel_mps2", _MOTION_NUMBERS)
    stop_decel = motion.number("stop_decel_mps2", _MOTION_NUMBERS)
    problem = stop_decel_problem(stop_decel, accel)
    if problem is not None:
        motion.fail("stop_decel_mps2", problem)
    return MotionConfig(
        speed_mps=speed,
        accel_mps2=accel,
        grasp_speed_mps=grasp_speed,
        stop_decel_mps2=stop_decel,
        timeout_margin_s=motion.number("timeout_margin_s", _MOTION_NUMBERS),
        joint_speed_rps=motion.number("joint_speed_rps", _MOTION_NUMBERS),
        joint_accel_rps2=motion.number("joint_accel_rps2", _MOTION_NUMBERS),
        blend_mm=motion.number("blend_mm", _MOTION_NUMBERS),
        blend_always=motion.boolean("blend_always", default=False),
    )


def read_workspace(top: Fields) -> WorkspaceConfig:
    """``workspace``: the box's corners in the base frame (mm), each axis at least
    ``MIN_WORKSPACE_EXTENT_MM`` long, and ``max_tilt_deg``."""
    workspace = top.section("workspace", ("min_mm", "max_mm", *_WORKSPACE_NUMBERS))
    corners = {}
    for key in ("min_mm", "max_mm"):
        corner = workspace.vector(key, 3)
        if np.any(np.abs(corner) > MAX_WORKSPACE_MM):
            workspace.fail(
                key, f"coordinates must lie within +-{MAX_WORKSPACE_MM:g} mm, got {corner.tolist()}"
            )
        corners[key] = corner
    extent = corners["max_mm"] - corners["min_mm"]
    for axis, size in zip("xyz", extent, strict=True):
        if size < MIN_WORKSPACE_EXTENT_MM:
            workspace.fail(
                "max_mm",
                f"{axis} must be at least {MIN_WORKSPACE_EXTENT_MM:g} mm above min_mm "
                f"(min {corners['min_mm'].tolist()}, max {corners['max_mm'].tolist()}; "
                "min above max, or metres given?)",
            )
    lo, hi = corners["min_mm"], corners["max_mm"]
    return WorkspaceConfig(
        min_mm=(float(lo[0]), float(lo[1]), float(lo[2])),
        max_mm=(float(hi[0]), float(hi[1]), float(hi[2])),
        max_tilt_deg=workspace.number("max_tilt_deg", _WORKSPACE_NUMBERS),
    )
