"""Eye-to-hand collection poses: the board's centre is held at the point, its face turned toward
the fixed camera within the tilt limit, poses differ enough, the feasibility callback decides
about the flange poses returned, and a point the camera cannot see is refused."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from handeye_pick.calibration.poses_eye_to_hand import propose_board_poses
from handeye_pick.errors import InputError
from handeye_pick.geometry import invert, rotation_angle_between, ur_pose_to_matrix

Matrix = NDArray[np.float64]
T_BASE_CAM = ur_pose_to_matrix([-0.45, 0.1, 1.0, math.pi, 0.0, 0.0])  # 1 m up, looking down
T_FLANGE_OBJ = ur_pose_to_matrix([0.0, 0.1, 0.03, 0.0, 0.0, 0.0])
LOOK_AT = np.array([-0.45, 0.1, 0.35])


def always(T_base_flange: Matrix) -> bool:
    return True


def face_angle_deg(T_base_obj: Matrix, T_base_cam: Matrix) -> float:
    """Angle between the board's face normal (-z, out of the printed face) and the direction
    from the board's centre to the camera."""
    to_camera = T_base_cam[:3, 3] - T_base_obj[:3, 3]
    cosine = -T_base_obj[:3, 2] @ to_camera / np.linalg.norm(to_camera)
    return math.degrees(math.acos(float(np.clip(cosine, -1.0, 1.0))))


@settings(max_examples=10, deadline=None)
@given(
    count=st.integers(4, 20),
    camera=st.tuples(
        st.floats(-0.6, 0.6), st.floats(-0.6, 0.6), st.floats(0.8, 1.5),  # position, m
        st.floats(-0.4, 0.4), st.floats(-0.4, 0.4), st.floats(-math.pi, math.pi),  # tilt, yaw
    ),
    along_axis_m=st.floats(0.3, 0.9),
    off_axis_m=st.tuples(st.floats(-0.1, 0.1), st.floats(-0.1, 0.1)),
    mount=st.tuples(*([st.floats(-0.1, 0.1)] * 3), *([st.floats(-1.0, 1.0)] * 3)),
)  # fmt: skip
def test_the_board_is_held_at_the_point_facing_the_camera(
    count: int,
    camera: tuple[float, ...],
    along_axis_m: float,
    off_axis_m: tuple[float, float],
    mount: tuple[float, ...],
) -> None:
    x, y, z, tilt_x, tilt_y, yaw = camera
    T_base_cam = ur_pose_to_matrix([x, y, z, math.pi + tilt_x, tilt_y, 0.0]) @ ur_pose_to_matrix(
        [0, 0, 0, 0, 0, yaw]
    )
    look_at = T_base_cam[:3, :3] @ np.array([*off_axis_m, along_axis_m]) + T_base_cam[:3, 3]
    T_flange_obj = ur_pose_to_matrix(list(mount))
    asked: list[Matrix] = []

    def feasible(T_base_flange: Matrix) -> bool:
        asked.append(T_base_flange)
        return True

    poses = propose_board_poses(look_at, count, T_base_cam, T_flange_obj, feasible)
    assert len(poses) == count
    for T_base_flange in poses:
        assert any(np.array_equal(T_base_flange, T) for T in asked)  # the callback saw it
        T_base_obj = T_base_flange @ T_flange_obj
        np.testing.assert_allclose(T_base_obj[:3, 3], look_at, atol=1e-9)
        assert face_angle_deg(T_base_obj, T_base_cam) <= 40.0 + 1e-6
    angles = [
        math.degrees(rotation_angle_between(a[:3, :3], b[:3, :3]))
        for i, a in enumerate(poses)
        for b in poses[i + 1 :]
    ]
    assert min(angles) >= 30.0 - 1e-9


def test_the_first_pose_shows_the_board_face_on() -> None:
    first = propose_board_poses(LOOK_AT, 6, T_BASE_CAM, T_FLANGE_OBJ, always)[0]
    T_cam_obj = invert(T_BASE_CAM) @ first @ T_FLANGE_OBJ
    np.testing.assert_allclose(T_cam_obj[:3, :3], np.eye(3), atol=1e-9)
    np.testing.assert_allclose(T_cam_obj[:3, 3], [0.0, 0.0, 0.65], atol=1e-9)


def test_only_feasible_flange_poses_are_kept() -> None:
    verdicts: list[bool] = []

    def face_up_within_25_deg(T_base_flange: Matrix) -> bool:
        verdicts.append(bool((T_base_flange @ T_FLANGE_OBJ)[2, 2] < -0.9))  # board z down
        return verdicts[-1]

    poses = propose_board_poses(LOOK_AT, 5, T_BASE_CAM, T_FLANGE_OBJ, face_up_within_25_deg)
    assert all((T @ T_FLANGE_OBJ)[2, 2] < -0.9 for T in poses)
    assert not all(verdicts)  # some were asked about and refused


@pytest.mark.parametrize(
    ("look_at", "message"),
    [
        ([-0.45, 0.1, 1.5], "off the camera's optical axis"),  # behind the camera
        ([0.5, 0.1, 0.9], "off the camera's optical axis"),  # beside it
        ([-0.45, 0.1, 0.98], "from the camera"),  # touching the lens
    ],
    ids=["behind", "beside", "too-close"],
)
def test_a_point_the_camera_cannot_see_is_refused(look_at: list[float], message: str) -> None:
    with pytest.raises(InputError, match=message):
        propose_board_poses(np.array(look_at), 6, T_BASE_CAM, T_FLANGE_OBJ, always)


def test_too_few_reachable_poses_name_the_board_point() -> None:
    with pytest.raises(InputError, match=r"eye-to-hand, board centre at \[-450.0, 100.0, 350.0\]"):
        propose_board_poses(LOOK_AT, 6, T_BASE_CAM, T_FLANGE_OBJ, lambda T: False)
