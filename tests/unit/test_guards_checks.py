"""Pure checks a one-line change could remove unnoticed (issue 21): the config loader's grasp
speed cap, the eye-to-hand camera's view of the workspace, and ``calibrate``'s refusal of a
dataset whose rotations are too small. No robot: the config, the hand-eye file and the dataset
are files on disk, read through the public loaders and the command line."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from handeye_pick import load_config
from handeye_pick.cli import main
from handeye_pick.errors import ConfigError
from handeye_pick.geometry import Transform, invert, make_transform, ur_pose_to_matrix
from handeye_pick.hand_eye.files import (
    CELL_CONFIG,
    HandEyeCalibration,
    HandEyeMode,
    load_hand_eye,
    write_zivid_transform,
)
from handeye_pick.hand_eye.plausibility import MeasuredCamera, chain_problems
from handeye_pick.limits import MAX_GRASP_SPEED_MPS, MAX_SPEED_MPS
from tests.integration.test_pick_cli import write_config
from tests.unit.handeye_helpers import errors, write_dataset

# --- the config loader caps the grasp speed on its own --------------------------------------------


def test_the_config_loader_refuses_a_grasp_speed_above_the_grasp_cap(tmp_path: Path) -> None:
    """Guards the grasp speed's own maximum in the config loader (config/schema.py, the
    ``grasp_speed_mps`` number read with ``maximum=MAX_GRASP_SPEED_MPS``): with the general
    speed at its cap, 0.3 m/s is faster than nothing else allows, and only the grasp cap
    (0.25 m/s) refuses it."""
    assert MAX_GRASP_SPEED_MPS < 0.3 < MAX_SPEED_MPS
    motion = f"  speed_mps: {MAX_SPEED_MPS}\n  accel_mps2: 1.2\n  grasp_speed_mps: 0.3\n"
    with pytest.raises(ConfigError, match=r"motion\.grasp_speed_mps") as caught:
        load_config(write_config(tmp_path, "127.0.0.2", motion=motion))
    assert f"{MAX_GRASP_SPEED_MPS:g}" in str(caught.value)
    at_cap = f"  speed_mps: {MAX_SPEED_MPS}\n  accel_mps2: 1.2\n  grasp_speed_mps: 0.25\n"
    assert load_config(write_config(tmp_path, "127.0.0.2", motion=at_cap)).motion.grasp_speed_mps


# --- camera-looks-at-workspace counts only what lies in front of the camera -----------------------


def _eye_to_hand(tmp_path: Path, T_base_cam: Transform) -> HandEyeCalibration:
    """An eye-to-hand calibration file holding ``T_base_cam`` (m), loaded as a cell loads it."""
    path = tmp_path / "eye_to_hand.yaml"
    write_zivid_transform(path, T_base_cam, "mm")
    return load_hand_eye(path, HandEyeMode.EYE_TO_HAND, "mm", False, settings=CELL_CONFIG)


@pytest.mark.parametrize("looks", ["down", "up"])
def test_a_workspace_behind_a_fixed_camera_is_not_in_its_view(tmp_path: Path, looks: str) -> None:
    """Guards the ray of ``_ray_meets_box`` (hand_eye/plausibility.py, ``s_in, s_out =
    0.0, math.inf``: only s >= 0, what lies in front of the camera). A camera 1 m above the
    workspace box (x, y within it): looking down it sees the box; looking up (an inverted
    mount), the line of its optical axis still crosses the box, but behind the camera, and
    ``camera-looks-at-workspace`` refuses it. Its position is measured and right, so only the
    view is judged."""
    workspace = load_config(write_config(tmp_path, "127.0.0.2")).workspace
    assert workspace.max_mm[2] < 1000.0 - 100.0  # the camera is above the box, grown
    eye_mm = (0.0, 500.0, 1000.0)
    flip = -1.0 if looks == "down" else 1.0
    R = np.diag([1.0, flip, flip])  # the optical axis (camera z) is base z times flip
    calibration = _eye_to_hand(tmp_path, make_transform(R, np.array(eye_mm) / 1000.0))
    problems = chain_problems(calibration, None, None, workspace, measured=MeasuredCamera(eye_mm))
    checks = [problem.check for problem in problems]
    assert checks == ([] if looks == "down" else ["camera-looks-at-workspace"])


# --- calibrate refuses rotations too small to separate rotation from translation ------------------

MIN_ROTATION_DEG = 10.0  # the README's minimum: no two poses 10 degrees apart is refused
T_FLANGE_CAM = ur_pose_to_matrix([0.04, -0.07, 0.09, 0.1, -0.15, 1.6])
# A flange pose above the table, turned about no particular axis (not a half turn, under which
# a mix-up of R_i^T R_j with R_i R_j would still give small rotations).
T_BASE_FLANGE_0 = ur_pose_to_matrix([0.45, -0.1, 0.5, 2.0, -1.2, 0.5])


def _dataset_turning_by(tmp_path: Path, tilt_deg: float) -> Path:
    """An exact eye-in-hand dataset of seven flange poses: the first, and the first turned by
    +-``tilt_deg`` about its own x, y and z in turn (so the largest relative rotation is
    2 * ``tilt_deg``, between opposite turns about one axis, and the axes spread widely), each
    shifted a few cm; the board 0.4 m in front of the camera."""
    T_base_board = T_BASE_FLANGE_0 @ T_FLANGE_CAM @ ur_pose_to_matrix([0.0, 0.0, 0.4, 0, 0, 0])
    a = math.radians(tilt_deg)
    turns = [[0, 0, 0], [a, 0, 0], [-a, 0, 0], [0, a, 0], [0, -a, 0], [0, 0, a], [0, 0, -a]]
    captures = []
    for k, turn in enumerate(turns):
        shift = [0.03 * (k % 3), 0.02 * (k % 2), -0.01 * k]
        T_base_flange = T_BASE_FLANGE_0 @ ur_pose_to_matrix([*shift, *turn])
        captures.append(
            (T_base_flange, invert(T_FLANGE_CAM) @ invert(T_base_flange) @ T_base_board)
        )
    return write_dataset(tmp_path / f"turning_{tilt_deg:g}_deg", captures)


def test_calibrate_refuses_rotations_all_below_the_minimum_and_solves_just_above(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Guards the minimum rotation of the motion check (calibration/rotation_spread.py,
    ``if spread.largest_rotation_deg < MIN_ROTATION_DEG`` and ``MIN_ROTATION_DEG = 10.0``; the
    relative rotations ``R_i^T R_j`` it measures) and the solver's call of it
    (calibration/solver.py, ``warnings += check_motion(motion_spread(...))``). Exact data
    whose poses are at most 9 degrees apart is refused for its small rotations (exit 2, nothing
    written), not solved nor refused for another reason; the same poses 11 degrees apart are
    solved, to the truth."""
    small = _dataset_turning_by(tmp_path, 0.45 * MIN_ROTATION_DEG)
    status = main(["calibrate", "--mode", "eye-in-hand", str(small)])
    err = capsys.readouterr().err
    assert status == 2, err
    assert "rotations too small to separate the camera's rotation from its translation" in err
    assert "is 9.0 deg (at least 10 deg needed" in err
    assert list(small.glob("hand_eye*")) == []

    enough = _dataset_turning_by(tmp_path, 0.55 * MIN_ROTATION_DEG)
    status = main(["calibrate", "--mode", "eye-in-hand", str(enough)])
    err = capsys.readouterr().err
    assert status == 0, err
    solved = load_hand_eye(enough / "hand_eye_transform.yaml", HandEyeMode.EYE_IN_HAND, "mm", False)
    distance_mm, angle_deg = errors(solved.T_cal, T_FLANGE_CAM)
    assert distance_mm < 1e-3
    assert angle_deg < 1e-4
