"""Synthetic hand-eye datasets for the tests: mocks/handeye_scene captures as pairs or files."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from handeye_pick.calibration.dataset import HandEyePair, object_pose_path, robot_pose_path
from handeye_pick.geometry import rotation_angle_between
from handeye_pick.hand_eye.files import HandEyeMode, write_zivid_transform

Captures = list[tuple[NDArray[np.float64], NDArray[np.float64]]]

# Non-contiguous and not starting at 0: pairs are named by their number, never by position.
NUMBERS = tuple(range(3, 200, 4))

MODES = (HandEyeMode.EYE_IN_HAND, HandEyeMode.EYE_TO_HAND)


def as_pairs(captures: Captures, numbers: Sequence[int] = NUMBERS) -> list[HandEyePair]:
    return [HandEyePair(n, a, b) for n, (a, b) in zip(numbers, captures, strict=False)]


def write_dataset(folder: Path, captures: Captures, numbers: Sequence[int] = NUMBERS) -> Path:
    """Write each capture as robot_pose_N.yaml and object_pose_N.yaml in Zivid's format (mm)."""
    folder.mkdir(parents=True, exist_ok=True)
    for number, (T_base_flange, T_cam_obj) in zip(numbers, captures, strict=False):
        write_zivid_transform(robot_pose_path(folder, number), T_base_flange)
        write_zivid_transform(object_pose_path(folder, number), T_cam_obj)
    return folder


def errors(T: NDArray[np.float64], truth: NDArray[np.float64]) -> tuple[float, float]:
    """Distance (mm) and angle (deg) between two transforms."""
    distance_mm = float(np.linalg.norm(T[:3, 3] - truth[:3, 3])) * 1e3
    return distance_mm, float(np.degrees(rotation_angle_between(T[:3, :3], truth[:3, :3])))
