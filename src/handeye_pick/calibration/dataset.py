"""A hand-eye dataset on disk: a folder of numbered pairs of pose files.

Pair ``N`` is two files, both in Zivid's matrix YAML (or the legacy OpenCV YAML, or a plain 4x4;
see ``calibration``), translation in millimetres unless declared otherwise:

- ``robot_pose_N.yaml``: ``T_base_flange``, the flange pose in the robot base frame at capture N
  (no TCP offset), as the controller reported it.
- ``object_pose_N.yaml``: ``T_cam_obj``, the calibration object's pose in the camera frame at
  capture N, as the integrator's detector measured it.

``N`` is a non-negative decimal number; numbers need not start at 0 or be contiguous, and they
name the pair everywhere (residuals, suspects, ``--exclude``). Other files in the folder (the
result and residual files ``calibrate`` writes there, images, notes) are ignored; a file whose
name starts like a pose file but does not match the pattern is an error, so a typo never drops
a pair silently.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from handeye_pick.errors import CalibrationError
from handeye_pick.geometry import LengthUnit, Transform
from handeye_pick.hand_eye.files import read_object_pose_file, read_robot_pose_file

ROBOT_POSE_PREFIX = "robot_pose_"
OBJECT_POSE_PREFIX = "object_pose_"
_NUMBERED = re.compile(r"^(robot_pose|object_pose)_(\d+)\.yaml$")


@dataclass(frozen=True, eq=False)
class HandEyePair:
    """One capture: the robot pose and the object pose measured at it (both metres)."""

    number: int  # N of the file names
    T_base_flange: Transform  # flange pose in the robot base frame
    T_cam_obj: Transform  # calibration object's pose in the camera frame


def robot_pose_path(folder: Path, number: int) -> Path:
    """Where pair ``number``'s robot pose lives: ``folder/robot_pose_N.yaml``."""
    return Path(folder) / f"{ROBOT_POSE_PREFIX}{number}.yaml"


def object_pose_path(folder: Path, number: int) -> Path:
    """Where pair ``number``'s object pose lives: ``folder/object_pose_N.yaml``."""
    return Path(folder) / f"{OBJECT_POSE_PREFIX}{number}.yaml"


def read_dataset(
    folder: Path, units: LengthUnit = "mm", flag: str = "--units"
) -> list[HandEyePair]:
    """Every pair in ``folder``, sorted by number, poses in metres.

    ``units`` is the translation unit of every pose file (mm, Zivid's unit, by default); each
    pose is unit-checked by magnitude and ``flag`` names the option that declares the unit.
    Raises ``CalibrationError`` (exit 2) naming the file for a missing half, two files with the
    same number (``robot_pose_3.yaml`` and ``robot_pose_03.yaml``), a misnamed pose file, an
    unreadable or invalid transform, or a folder with no pairs.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise CalibrationError(f"dataset {folder} is not a folder")
    robot_files, object_files = _numbered_files(folder)
    for number, path in sorted(robot_files.items()):
        if number not in object_files:
            raise CalibrationError(
                f"{path} has no {object_pose_path(folder, number).name}: a pair needs both "
                "halves; capture it again or move the file away"
            )
    for number, path in sorted(object_files.items()):
        if number not in robot_files:
            raise CalibrationError(
                f"{path} has no {robot_pose_path(folder, number).name}: a pair needs both "
                "halves; capture it again or move the file away"
            )
    if not robot_files:
        raise CalibrationError(
            f"dataset {folder} holds no pairs (robot_pose_N.yaml with object_pose_N.yaml)"
        )
    return [
        HandEyePair(
            number=number,
            T_base_flange=read_robot_pose_file(robot_files[number], units, flag),
            T_cam_obj=read_object_pose_file(object_files[number], units, flag),
        )
        for number in sorted(robot_files)
    ]


def _numbered_files(folder: Path) -> tuple[dict[int, Path], dict[int, Path]]:
    """Robot and object pose files by number; refuses misnamed and duplicate numbers."""
    found: dict[str, dict[int, Path]] = {"robot_pose": {}, "object_pose": {}}
    for path in sorted(folder.iterdir()):
        name = path.name
        if not name.startswith((ROBOT_POSE_PREFIX, OBJECT_POSE_PREFIX)):
            continue
        match = _NUMBERED.match(name)
        if match is None or not path.is_file():
            raise CalibrationError(
                f"{path}: a pose file must be named robot_pose_N.yaml or object_pose_N.yaml "
                "with N a number (rename or move it)"
            )
        kind, number = match.group(1), int(match.group(2))
        earlier = found[kind].get(number)
        if earlier is not None:
            raise CalibrationError(
                f"{earlier} and {path} both hold pair {number}: keep one of them"
            )
        found[kind][number] = path
    return found["robot_pose"], found["object_pose"]
