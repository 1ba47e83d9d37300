"""Proposed collection poses: the camera looks at the point, poses differ enough, the
feasibility callback decides, and a dataset taken at them calibrates."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from handeye_pick.calibration.poses_eye_in_hand import propose_poses
from handeye_pick.calibration.rotation_spread import check_motion, motion_spread
from handeye_pick.calibration.solver import solve_hand_eye
from handeye_pick.errors import InputError
from handeye_pick.geometry import invert, rotation_angle_between, ur_pose_to_matrix
from handeye_pick.hand_eye.files import HandEyeMode
from tests.unit.handeye_helpers import as_pairs, errors

T_FLANGE_CAM = ur_pose_to_matrix([0.0, -0.07, 0.06, 0.0, 0.0, 0.1])
LOOK_AT = np.array([0.5, 0.1, 0.0])


def always(T_base_flange: NDArray[np.float64]) -> bool:
    return True


@settings(max_examples=10, deadline=None)
@given(
    count=st.integers(4, 25),
    distance_m=st.floats(0.25, 1.0),
    look_at=st.tuples(*(st.floats(-0.8, 0.8) for _ in range(3))).map(np.array),
)
def test_the_camera_looks_at_the_point_from_distinct_directions(
    count: int, distance_m: float, look_at: NDArray[np.float64]
) -> None:
    poses = propose_poses(look_at, distance_m, count, T_FLANGE_CAM, always)
    assert len(poses) == count
    for T_base_flange in poses:
        T_cam_base = invert(T_base_flange @ T_FLANGE_CAM)
        # The point is on the optical axis (camera z), distance_m ahead.
        p_cam = T_cam_base[:3, :3] @ look_at + T_cam_base[:3, 3]
        np.testing.assert_allclose(p_cam, [0.0, 0.0, distance_m], atol=1e-9)
    angles = [
        math.degrees(rotation_angle_between(a[:3, :3], b[:3, :3]))
        for i, a in enumerate(poses)
        for b in poses[i + 1 :]
    ]
    assert min(angles) >= 30.0 - 1e-9
    # calibrate would accept them without a warning about the motion.
    spread = motion_spread(np.stack([T[:3, :3] for T in poses]), list(range(count)))
    assert check_motion(spread) == []


def test_the_first_pose_looks_straight_down_and_the_choice_is_deterministic() -> None:
    first = propose_poses(LOOK_AT, 0.5, 8, T_FLANGE_CAM, always)
    second = propose_poses(LOOK_AT, 0.5, 8, T_FLANGE_CAM, always)
    assert all(np.array_equal(a, b) for a, b in zip(first, second, strict=True))
    camera_z_in_base = (first[0] @ T_FLANGE_CAM)[:3, 2]
    np.testing.assert_allclose(camera_z_in_base, [0.0, 0.0, -1.0], atol=1e-12)


def test_only_poses_the_callback_accepts_are_proposed() -> None:
    asked: list[NDArray[np.float64]] = []

    def flange_not_behind_the_point(T_base_flange: NDArray[np.float64]) -> bool:
        asked.append(T_base_flange)
        return bool(T_base_flange[0, 3] <= LOOK_AT[0])

    poses = propose_poses(LOOK_AT, 0.5, 10, T_FLANGE_CAM, flange_not_behind_the_point)
    assert len(poses) == 10
    assert all(T[0, 3] <= LOOK_AT[0] for T in poses)
    assert len(asked) > 10  # some were refused and others taken instead
    assert any(T[0, 3] > LOOK_AT[0] for T in asked)


def test_too_few_reachable_poses_is_an_error() -> None:
    with pytest.raises(InputError, match="only 0 reachable poses"):
        propose_poses(LOOK_AT, 0.5, 6, T_FLANGE_CAM, lambda T: False)
    with pytest.raises(InputError, match=r"only 7 reachable poses .* tilted 10 deg or less"):
        propose_poses(LOOK_AT, 0.5, 40, T_FLANGE_CAM, always, max_tilt_deg=10.0)


@pytest.mark.parametrize(
    ("args", "message"),
    [((LOOK_AT, 0.5, 3), "at least 4 poses"),
     ((LOOK_AT, 0.0, 8), "distance must be > 0"),
     ((np.array([0.5, np.nan, 0.0]), 0.5, 8), "3 finite numbers")],
)  # fmt: skip
def test_bad_arguments_are_refused(
    args: tuple[NDArray[np.float64], float, int], message: str
) -> None:
    with pytest.raises(InputError, match=message):
        propose_poses(*args, T_FLANGE_CAM, always)


def test_a_dataset_taken_at_the_proposed_poses_calibrates() -> None:
    T_base_obj = ur_pose_to_matrix([*LOOK_AT, math.pi, 0.0, 0.4])
    poses = propose_poses(LOOK_AT, 0.45, 12, T_FLANGE_CAM, always)
    captures = [(T, invert(T_FLANGE_CAM) @ invert(T) @ T_base_obj) for T in poses]
    result = solve_hand_eye(as_pairs(captures), HandEyeMode.EYE_IN_HAND)
    distance_mm, angle_deg = errors(result.fit.T_cal, T_FLANGE_CAM)
    assert distance_mm < 1e-6
    assert angle_deg < 1e-7
    assert result.warnings == ()
