"""Robot poses for collecting an eye-to-hand dataset: a board on the flange, turned toward a
fixed camera.

Eye-in-hand (``poses_eye_in_hand.propose_poses``) moves a camera around a fixed board. Eye-to-hand
needs the same views from the other side: the board is held at a point the camera sees and
turned so that the camera sees it as a camera circling it would. The poses are therefore
proposed for a virtual camera circling the board (in the board's frame, with the same tilt,
roll and separation rules), and each virtual view ``T_cam_obj`` is turned into the flange pose
that shows the board to the fixed camera the same way:
``T_base_flange = T_base_los @ T_cam_obj @ inv(T_flange_obj)``, where ``los`` is the camera
turned to look straight at the board's centre (the line of sight).

Frames and units: metres and float64 4x4. The board frame is the detector's (origin at the
board's centre, z into the board, away from the printed face), as Zivid and OpenCV's
``solvePnP`` give it.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from handeye_pick.calibration.poses_eye_in_hand import Feasible, propose_poses
from handeye_pick.errors import InputError
from handeye_pick.geometry import Transform, invert, make_transform, rotation_from_rotvec

MAX_OFF_AXIS_DEG = 45.0
"""A board centre farther than this from the camera's optical axis is outside any 3D camera's
view (a Zivid 2+ sees about 24 degrees off axis)."""

MIN_DISTANCE_M = 0.05  # no 3D camera sees a whole board this close (and at 0 no line of sight)
# The board lies at the origin of the virtual camera's world, face up (z into the board, so
# down), where a straight-down camera sees it face on.
_T_WORLD_OBJ = make_transform(rotation_from_rotvec([math.pi, 0.0, 0.0]), np.zeros(3))


def propose_board_poses(
    look_at_base_m: ArrayLike,
    count: int,
    T_base_cam: Transform,
    T_flange_obj: Transform,
    feasible: Feasible,
    *,
    max_tilt_deg: float = 40.0,
    min_separation_deg: float = 30.0,
) -> list[Transform]:
    """``count`` flange poses ``T_base_flange`` (m) that hold the board's centre at
    ``look_at_base_m`` (base, m), its face turned toward the fixed camera at ``T_base_cam``
    (m, known roughly before calibrating) by up to ``max_tilt_deg`` from face on, and rolled.

    ``T_flange_obj`` is the board's mount on the flange (m, roughly). ``feasible`` is asked
    about each flange pose before it is chosen. Raises ``InputError`` when the point is not in
    front of the camera, or as ``propose_poses`` does (too few reachable, too alike).
    """
    target = np.asarray(look_at_base_m, dtype=np.float64)
    if not (target.shape == (3,) and np.all(np.isfinite(target))):
        raise InputError(f"look-at point must be 3 finite numbers (m), got {target.tolist()}")
    T_base_los = _line_of_sight(T_base_cam, target)
    distance_m = float(np.linalg.norm(target - T_base_cam[:3, 3]))
    T_obj_flange = invert(T_flange_obj)

    def flange_pose(T_world_vcam: Transform) -> Transform:
        T_vcam_obj = invert(T_world_vcam) @ _T_WORLD_OBJ
        return T_base_los @ T_vcam_obj @ T_obj_flange

    try:
        views = propose_poses(
            np.zeros(3),
            distance_m,
            count,
            np.eye(4),
            lambda T: feasible(flange_pose(T)),
            max_tilt_deg=max_tilt_deg,
            min_separation_deg=min_separation_deg,
        )
    except InputError as exc:
        where = np.round(target * 1000.0, 1).tolist()
        raise InputError(
            f"eye-to-hand, board centre at {where} mm, {distance_m * 1000.0:.0f} mm from the "
            f"camera (proposed as views of a camera circling the board, in the board's frame): "
            f"{exc}"
        ) from None
    return [flange_pose(T) for T in views]


def _line_of_sight(T_base_cam: Transform, target: ArrayLike) -> Transform:
    """The camera turned to look straight at ``target`` (base, m): origin at the camera, z
    toward the target, x as close to the camera's x as that allows. Refuses a target behind,
    beside or on top of the camera."""
    line = np.asarray(target, dtype=np.float64) - T_base_cam[:3, 3]
    distance = float(np.linalg.norm(line))
    if distance < MIN_DISTANCE_M:
        raise InputError(
            f"look-at point is {distance * 1000.0:.1f} mm from the camera: the board must be "
            "held in front of it, in view"
        )
    z = line / distance
    off_axis_deg = math.degrees(math.acos(float(np.clip(z @ T_base_cam[:3, 2], -1.0, 1.0))))
    if off_axis_deg > MAX_OFF_AXIS_DEG:
        raise InputError(
            f"look-at point is {off_axis_deg:.0f} deg off the camera's optical axis (at most "
            f"{MAX_OFF_AXIS_DEG:g}): the camera cannot see the board there; check the point "
            "and the camera's mount"
        )
    x = T_base_cam[:3, 0] - (T_base_cam[:3, 0] @ z) * z  # nonzero: z is within 45 deg of cam z
    x /= np.linalg.norm(x)
    return make_transform(np.column_stack([x, np.cross(z, x), z]), T_base_cam[:3, 3])
