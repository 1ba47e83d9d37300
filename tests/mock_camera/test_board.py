"""The calibration board's measured pose T_cam_obj: exact through the chain, noisy as stated."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from handeye_pick.hand_eye.files import read_transform_file
from mocks.camera import (
    BoardNotVisible,
    CalibrationBoard,
    PoseNoise,
    Scene,
    SimulatedCamera,
    read_zivid_matrix,
    write_zivid_matrix,
)
from tests.mock_camera.helpers import looking_down, pose, rotation_angle_deg

EXACT = PoseNoise(translation_mm=0.0, rotation_deg=0.0)
T_FLANGE_CAM = pose(0.0, -0.075, 0.055, 0.0, 0.0, math.pi / 2)
T_BASE_FLANGE = pose(-0.45, -0.13, 0.60, math.pi, 0.0, 0.0)  # tool straight down
# On the table below the camera, printed face up: its z (into the board) points down.
T_BASE_BOARD = pose(-0.50, -0.12, 0.0, math.pi, 0.0, 0.2)


def _mm(T_m: np.ndarray) -> np.ndarray:
    T = T_m.copy()
    T[:3, 3] *= 1000.0
    return T


def test_eye_in_hand_exact_pose_is_the_chain_through_the_flange() -> None:
    camera = SimulatedCamera(Scene(), T_flange_cam=T_FLANGE_CAM, pose_noise=EXACT)
    measured = camera.object_pose_mm(CalibrationBoard.in_cell(T_BASE_BOARD), T_BASE_FLANGE)
    expected = np.linalg.inv(T_BASE_FLANGE @ T_FLANGE_CAM) @ T_BASE_BOARD
    np.testing.assert_allclose(measured, _mm(expected), atol=1e-9)


def test_eye_to_hand_exact_pose_is_the_chain_through_the_carried_board() -> None:
    T_base_cam = pose(-0.45, -0.13, 0.0, 0.0, 0.0, 0.3)  # on the floor, looking up
    T_flange_board = pose(0.01, 0.0, 0.02, math.pi, 0.0, 0.0)  # printed face down
    camera = SimulatedCamera(Scene(), T_base_cam=T_base_cam, pose_noise=EXACT)
    measured = camera.object_pose_mm(CalibrationBoard.on_flange(T_flange_board), T_BASE_FLANGE)
    expected = np.linalg.inv(T_base_cam) @ T_BASE_FLANGE @ T_flange_board
    np.testing.assert_allclose(measured, _mm(expected), atol=1e-9)


@settings(max_examples=50, deadline=None)
@given(
    flange=st.tuples(*[st.floats(-1.0, 1.0)] * 3, *[st.floats(-3.0, 3.0)] * 3),
    distance_m=st.floats(0.2, 1.5),
    offset=st.tuples(st.floats(-0.3, 0.3), st.floats(-0.2, 0.2)),
    # Tilted at most 40 deg, seen at most 20 deg off axis: within the 70 deg a detector takes.
    turn=st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5), st.floats(-math.pi, math.pi)),
)
def test_a_board_put_in_front_of_the_camera_is_measured_there(
    flange: tuple[float, ...], distance_m: float, offset: tuple[float, float],
    turn: tuple[float, float, float],
) -> None:
    T_cam_board = pose(offset[0] * distance_m, offset[1] * distance_m, distance_m, *turn)
    T_base_flange = pose(*flange)
    T_base_board = T_base_flange @ T_FLANGE_CAM @ T_cam_board
    camera = SimulatedCamera(Scene(), T_flange_cam=T_FLANGE_CAM, pose_noise=EXACT)
    measured = camera.object_pose_mm(CalibrationBoard.in_cell(T_base_board), T_base_flange)
    np.testing.assert_allclose(measured, _mm(T_cam_board), atol=1e-7)


def test_the_noise_has_the_stated_spread_larger_along_the_optical_axis() -> None:
    camera = SimulatedCamera(Scene(), T_flange_cam=T_FLANGE_CAM, seed=7)  # default noise
    board = CalibrationBoard.in_cell(T_BASE_BOARD)
    exact = _mm(np.linalg.inv(T_BASE_FLANGE @ T_FLANGE_CAM) @ T_BASE_BOARD)
    draws = [camera.object_pose_mm(board, T_BASE_FLANGE) for _ in range(2000)]
    offsets_mm = np.array([T[:3, 3] - exact[:3, 3] for T in draws])
    turns_deg = np.degrees([Rotation.from_matrix(T[:3, :3] @ exact[:3, :3].T).as_rotvec()
                            for T in draws])
    # 2000 draws: a standard deviation is known to about 1.6 %, a mean to 2.2 % of sigma.
    np.testing.assert_allclose(offsets_mm.std(axis=0), [0.1, 0.1, 0.3], rtol=0.08)
    np.testing.assert_allclose(offsets_mm.mean(axis=0), 0.0, atol=0.01)
    np.testing.assert_allclose(turns_deg.std(axis=0), 0.02, rtol=0.08)
    np.testing.assert_allclose(turns_deg.mean(axis=0), 0.0, atol=0.002)


def test_the_same_seed_gives_the_same_measurements_and_another_seed_others() -> None:
    board = CalibrationBoard.in_cell(T_BASE_BOARD)

    def measure(seed: int | tuple[int, ...]) -> list[np.ndarray]:
        camera = SimulatedCamera(Scene(), T_flange_cam=T_FLANGE_CAM, seed=seed)
        return [camera.object_pose_mm(board, T_BASE_FLANGE) for _ in range(3)]

    first = measure(3)
    np.testing.assert_array_equal(first, measure(3))
    assert not np.allclose(first[0], first[1])  # each call draws afresh
    assert not np.allclose(first[0], measure(4)[0])
    assert not np.allclose(measure((3, 0))[0], measure((3, 1))[0])


@pytest.mark.parametrize(
    ("T_base_board", "reason"),
    [
        (pose(-0.50, -0.12, 1.5, math.pi, 0.0, 0.0), "behind the camera"),
        (pose(0.50, -0.12, 0.0, math.pi, 0.0, 0.0), "off the image"),
        (pose(-0.50, -0.12, 0.0, 0.0, 0.0, 0.0), "seen at 180 deg"),  # printed face down
        (pose(-0.50, -0.12, 0.0, math.pi - math.radians(75), 0.0, 0.0), "seen at 75 deg"),
    ],
)
def test_a_board_the_camera_cannot_see_is_not_measured(T_base_board: np.ndarray,
                                                       reason: str) -> None:
    camera = SimulatedCamera(Scene(), T_base_cam=looking_down(-0.5, -0.12, 0.5))
    board = CalibrationBoard.on_flange(np.linalg.inv(T_BASE_FLANGE) @ T_base_board)
    with pytest.raises(BoardNotVisible, match=reason):
        camera.object_pose_mm(board, T_BASE_FLANGE)


def test_a_board_fixed_to_the_same_body_as_the_camera_is_refused() -> None:
    camera = SimulatedCamera(Scene(), T_flange_cam=T_FLANGE_CAM)
    with pytest.raises(ValueError, match="board fixed to the base, not to the flange"):
        camera.object_pose_mm(CalibrationBoard.on_flange(np.eye(4)), T_BASE_FLANGE)


def test_noise_must_not_be_negative() -> None:
    with pytest.raises(ValueError, match="translation_mm must be finite and >= 0"):
        PoseNoise(translation_mm=-0.1)


def test_a_written_pose_reads_back_exactly_and_as_handeye_pick_reads_zivid_files(
    tmp_path: Path,
) -> None:
    camera = SimulatedCamera(Scene(), T_flange_cam=T_FLANGE_CAM, seed=1)
    T_cam_obj_mm = camera.object_pose_mm(CalibrationBoard.in_cell(T_BASE_BOARD), T_BASE_FLANGE)
    path = tmp_path / "object_pose_0.yaml"
    write_zivid_matrix(path, T_cam_obj_mm)
    text = path.read_text()
    assert "__version__:\n  serializer: 1\n  data: 1\nFloatMatrix:\n  Data: [" in text
    np.testing.assert_array_equal(read_zivid_matrix(path), T_cam_obj_mm)
    T_m = read_transform_file(path, "mm")
    np.testing.assert_allclose(T_m[:3, 3] * 1000.0, T_cam_obj_mm[:3, 3], atol=1e-9)
    assert rotation_angle_deg(T_m[:3, :3], T_cam_obj_mm[:3, :3]) < 1e-6
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left behind
