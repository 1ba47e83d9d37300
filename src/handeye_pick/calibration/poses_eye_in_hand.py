"""Robot poses for collecting an eye-in-hand dataset: one point seen from varied directions.

The camera (optical frame as Zivid and OpenCV define it: z along the optical axis, x to the
right of the image, y down) is placed at ``distance_m`` from a base-frame point, looking straight
at it, from directions tilted up to ``max_tilt_deg`` from straight above, and rolled about its
optical axis. Hand-eye calibration needs rotations between poses of 30 degrees or more about
well-spread axes (OpenCV's and Zivid's guidance): tilting toward different sides turns the
camera about different horizontal axes, rolling turns it about the optical axis.

The candidates form a fixed grid (tilt x direction of tilt x roll). The first pose looks straight
down; each next one is the candidate whose smallest rotation to the poses already chosen is the
largest (farthest-point selection), as long as that rotation is at least
``min_separation_deg`` and ``feasible`` accepts the flange pose. The grid and the selection are
deterministic: the same arguments give the same poses.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from handeye_pick.calibration.rotation_spread import check_motion, motion_spread
from handeye_pick.calibration.solver import MIN_PAIRS
from handeye_pick.errors import CalibrationError, InputError
from handeye_pick.geometry import Transform, invert, make_transform

Feasible = Callable[[Transform], bool]
"""Takes ``T_base_flange`` (m); True when the robot can reach it (IK, workspace, safety)."""

_TILT_STEPS = 4  # tilts 0 .. max_tilt_deg
_DIRECTION_STEP_DEG = 30.0  # directions of tilt around the vertical
_ROLLS_DEG = (-90.0, -60.0, -30.0, 0.0, 30.0, 60.0, 90.0)  # about the optical axis
# Camera looking straight down with its x along the base x: half a turn about x.
_R_BASE_CAM_DOWN = Rotation.from_rotvec([math.pi, 0.0, 0.0])


def propose_poses(
    look_at_base_m: ArrayLike,
    distance_m: float,
    count: int,
    T_flange_cam: Transform,
    feasible: Feasible,
    *,
    max_tilt_deg: float = 40.0,
    min_separation_deg: float = 30.0,
) -> list[Transform]:
    """``count`` flange poses ``T_base_flange`` (m) whose camera looks at ``look_at_base_m``.

    ``T_flange_cam`` is the camera's mount on the flange (m), known roughly before calibrating
    (from the bracket's drawing). ``feasible`` is asked about each pose before it is chosen.
    Raises ``InputError`` when ``count`` is below the calibration minimum, when fewer than
    ``count`` feasible poses are ``min_separation_deg`` apart, or when the chosen poses would
    not pass calibrate's motion checks without a warning.
    """
    target = np.asarray(look_at_base_m, dtype=np.float64)
    if count < MIN_PAIRS:
        raise InputError(f"a hand-eye dataset needs at least {MIN_PAIRS} poses, asked for {count}")
    if not (target.shape == (3,) and np.all(np.isfinite(target))):
        raise InputError(f"look-at point must be 3 finite numbers (m), got {target.tolist()}")
    if not (math.isfinite(distance_m) and distance_m > 0):
        raise InputError(f"camera distance must be > 0 m, got {distance_m}")
    T_cam_flange = invert(T_flange_cam)
    candidates = [
        make_transform(R_base_cam, target - distance_m * R_base_cam[:, 2]) @ T_cam_flange
        for R_base_cam in _camera_rotations(max_tilt_deg)
    ]
    chosen = _farthest_feasible(candidates, count, min_separation_deg, feasible)
    if len(chosen) < count:
        raise InputError(
            f"only {len(chosen)} reachable poses look at {target.tolist()} m from "
            f"{distance_m} m, tilted {max_tilt_deg:g} deg or less, with {min_separation_deg:g} "
            f"deg or more between them; {count} asked: ask for fewer, or move the point or the "
            "distance into easier reach"
        )
    try:
        weak = check_motion(
            motion_spread(np.stack([T[:3, :3] for T in chosen]), list(range(count)))
        )
    except CalibrationError as exc:
        weak = [str(exc)]
    if weak:
        raise InputError(f"the reachable poses are too alike for a calibration: {weak[0]}")
    return chosen


def _camera_rotations(max_tilt_deg: float) -> list[NDArray[np.float64]]:
    """``R_base_cam`` of every candidate, straight down and unrolled first."""
    rotations = []
    for tilt in np.linspace(0.0, math.radians(max_tilt_deg), _TILT_STEPS):
        directions = [0.0] if tilt == 0.0 else np.arange(0.0, 360.0, _DIRECTION_STEP_DEG)
        for direction in np.radians(directions):
            # Tilt about the horizontal axis across the direction the camera leans toward.
            axis = np.array([-math.sin(direction), math.cos(direction), 0.0])
            lean = Rotation.from_rotvec(axis * tilt)
            for roll in np.radians(sorted(_ROLLS_DEG, key=abs)):
                R = lean * _R_BASE_CAM_DOWN * Rotation.from_rotvec([0.0, 0.0, roll])
                rotations.append(R.as_matrix())
    return rotations


def _farthest_feasible(
    candidates: list[Transform], count: int, min_separation_deg: float, feasible: Feasible
) -> list[Transform]:
    """Greedy farthest-point choice among ``candidates``, asking ``feasible`` before each."""
    remaining = list(candidates)
    chosen: list[Transform] = []
    # Smallest rotation (rad) from each remaining candidate to the chosen ones; inf when none.
    nearest = np.full(len(remaining), np.inf)
    while remaining and len(chosen) < count:
        best = int(np.argmax(nearest))  # ties: the first, so straight down starts
        if nearest[best] < math.radians(min_separation_deg):
            break
        T = remaining.pop(best)
        nearest = np.delete(nearest, best)
        if not feasible(T):
            continue
        chosen.append(T)
        if remaining:
            relative = np.stack([T[:3, :3].T @ C[:3, :3] for C in remaining])
            angles = np.linalg.norm(Rotation.from_matrix(relative).as_rotvec(), axis=1)
            nearest = np.minimum(nearest, angles)
    return chosen
