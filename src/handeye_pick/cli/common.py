"""Command-line pieces shared by the commands that turn camera data into robot-base data.

Each ``add_*_args`` adds one group of flags; the matching ``*_from_args`` reads them back into
validated values in the package's units (metres inside, millimetres for camera points). Commands
call these instead of defining their own flags, so ``--calibration`` means the same everywhere.
"""

from __future__ import annotations

import argparse
import logging
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from handeye_pick.errors import InputError
from handeye_pick.geometry import Transform
from handeye_pick.hand_eye.files import (
    HandEyeCalibration,
    HandEyeMode,
    load_hand_eye,
    read_robot_pose_file,
    robot_pose_from_ur_vector,
)
from handeye_pick.hand_eye.plausibility import (
    CAMERA_POSITION_TOLERANCE_MM,
    CHECKS,
    MAX_CAMERA_POSITION_TOLERANCE_MM,
    MeasuredCamera,
    chain_problems,
    measured_position_problem,
    refuse_implausible,
)

log = logging.getLogger(__name__)

UNITS = ("mm", "m")

# argparse of Python 3.10 and 3.11 takes "-2e-3" for an option name, so a number copied from JSON
# output fails; this is its own pattern for negative numbers, extended by an exponent.
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")


def accept_negative_exponents(parser: argparse.ArgumentParser) -> None:
    """Let numeric arguments of ``parser`` be written like -2e-3 (it has no such option names)."""
    parser._negative_number_matcher = _NEGATIVE_NUMBER


def add_hand_eye_args(parser: argparse.ArgumentParser, *, with_mode: bool = True) -> None:
    """Add ``--mode``, ``--calibration``, ``--calibration-units``, ``--invert`` and the
    plausibility flags ``--acknowledge``, ``--camera-position-mm`` and
    ``--camera-position-tolerance-mm``.

    With ``with_mode=False`` the command supplies the mode itself (``hand_eye_from_args(args,
    mode)``), e.g. from the cell configuration.
    """
    group = parser.add_argument_group("hand-eye calibration")
    if with_mode:
        group.add_argument(
            "--mode",
            required=True,
            choices=[m.value for m in HandEyeMode],
            help="eye-in-hand: camera on the flange, the file holds T_flange_cam; "
            "eye-to-hand: camera fixed in the cell, the file holds T_base_cam",
        )
    group.add_argument(
        "--calibration",
        required=True,
        type=Path,
        metavar="FILE",
        help="hand-eye result: Zivid YAML, legacy OpenCV YAML (%%YAML:1.0) or a plain "
        "YAML/JSON 4x4 (list, or {matrix, units})",
    )
    group.add_argument(
        "--calibration-units",
        choices=UNITS,
        default="mm",
        help="translation unit of the calibration file (default: mm, Zivid's unit)",
    )
    group.add_argument(
        "--invert",
        action="store_true",
        help="the file holds the inverse (T_cam_flange or T_cam_base); invert it on load. "
        "Nothing is ever inverted without this flag",
    )
    group.add_argument(
        "--acknowledge",
        action="append",
        default=[],
        choices=CHECKS,
        metavar="CHECK",
        help="accept one named plausibility check of the camera chain that this mount fails on "
        "purpose (repeat for several); the refusal names the check",
    )
    accept_negative_exponents(parser)
    group.add_argument(
        "--camera-position-mm",
        nargs=3,
        type=float,
        metavar=("X", "Y", "Z"),
        help="the camera's rough measured position (a tape measure will do), mm: in the robot "
        "base frame for eye-to-hand, in the flange frame for eye-in-hand. A calibration that "
        "puts the camera farther away is refused, and named inverted when its inverse fits",
    )
    group.add_argument(
        "--camera-position-tolerance-mm",
        type=float,
        metavar="MM",
        help="how far the calibration's camera origin may lie from --camera-position-mm, mm "
        f"(default {CAMERA_POSITION_TOLERANCE_MM:g}, at most "
        f"{MAX_CAMERA_POSITION_TOLERANCE_MM:g})",
    )


def add_robot_pose_args(parser: argparse.ArgumentParser) -> None:
    """Add ``--robot-pose FILE | --robot-pose-ur X Y Z RX RY RZ`` and ``--robot-pose-units``.

    Both give ``T_base_flange``, the flange pose in the robot base frame at capture time.
    """
    accept_negative_exponents(parser)
    group = parser.add_argument_group(
        "robot pose at capture time (eye-in-hand only): T_base_flange, the flange pose in the "
        "robot base frame"
    )
    choice = group.add_mutually_exclusive_group()
    choice.add_argument(
        "--robot-pose",
        type=Path,
        metavar="FILE",
        help="4x4 flange pose file like Zivid's RobotTransform.yaml (same formats as "
        "--calibration)",
    )
    choice.add_argument(
        "--robot-pose-ur",
        nargs=6,
        type=float,
        metavar=("X", "Y", "Z", "RX", "RY", "RZ"),
        help="flange pose as a UR pose vector: metres and a rotation vector in radians, as the "
        "pendant shows with the TCP offset set to zero",
    )
    group.add_argument(
        "--robot-pose-units",
        choices=UNITS,
        default="mm",
        help="translation unit of the --robot-pose file (default: mm, Zivid's unit)",
    )


def add_camera_point_args(parser: argparse.ArgumentParser, required: bool = True) -> None:
    """Add ``--xyz X Y Z`` (camera frame, mm) or ``--cloud FILE --pixel COL ROW``."""
    accept_negative_exponents(parser)
    group = parser.add_argument_group("point in the camera frame (mm)")
    choice = group.add_mutually_exclusive_group(required=required)
    choice.add_argument(
        "--xyz",
        nargs=3,
        type=float,
        metavar=("X", "Y", "Z"),
        help="point in the camera frame, mm",
    )
    choice.add_argument(
        "--cloud",
        type=Path,
        metavar="FILE",
        help="organized point cloud (.npy or .ply, camera frame, mm) to pick the point from; "
        "needs --pixel",
    )
    group.add_argument(
        "--pixel",
        nargs=2,
        type=int,
        metavar=("COL", "ROW"),
        help="image coordinates of the point in --cloud: column (x) then row (y), from 0",
    )


def hand_eye_from_args(
    args: argparse.Namespace, mode: HandEyeMode | None = None
) -> HandEyeCalibration:
    """Load the calibration named by the flags; ``mode`` overrides (or replaces) ``--mode``."""
    chosen = mode if mode is not None else HandEyeMode(args.mode)
    return load_hand_eye(args.calibration, chosen, units=args.calibration_units, invert=args.invert)


def robot_pose_from_args(args: argparse.Namespace) -> Transform | None:
    """``T_base_flange`` in metres from ``--robot-pose`` or ``--robot-pose-ur``; None if neither."""
    if args.robot_pose is not None:
        return read_robot_pose_file(args.robot_pose, units=args.robot_pose_units)
    if args.robot_pose_ur is not None:
        return robot_pose_from_ur_vector(args.robot_pose_ur, "--robot-pose-ur")
    return None


def camera_point_mm_from_args(args: argparse.Namespace) -> NDArray[np.float64] | None:
    """The camera-frame point in mm from ``--xyz`` or ``--cloud``/``--pixel``; None if neither."""
    if args.cloud is None:
        if args.pixel is not None:
            raise InputError("--pixel picks a point from --cloud, but no --cloud was given")
        if args.xyz is None:
            return None
        point = np.array(args.xyz, dtype=np.float64)
        if not np.all(np.isfinite(point)):
            raise InputError(f"--xyz must be finite numbers (mm), got {args.xyz}")
        return point
    if args.pixel is None:
        raise InputError(f"--cloud {args.cloud} needs --pixel COL ROW to choose the point")
    # Imported here: the cloud modules serve --cloud only, not --xyz or convert.
    from handeye_pick.cloud.files import read_cloud
    from handeye_pick.cloud.transform import pick_point

    col, row = args.pixel
    return pick_point(read_cloud(args.cloud).xyz, col, row)


@dataclass(frozen=True, eq=False)
class CameraChain:
    """The camera-to-base chain a command resolved from its flags (all metres)."""

    calibration: HandEyeCalibration
    T_base_flange: Transform | None  # flange pose at capture time; None for eye-to-hand
    T_base_cam: Transform  # camera pose in the robot base frame


def camera_chain_from_args(args: argparse.Namespace) -> CameraChain:
    """Load calibration and robot pose and build ``T_base_cam``.

    Eye-in-hand needs a robot pose; eye-to-hand refuses one, because a robot pose given with a
    fixed camera usually means the wrong ``--mode``.
    """
    calibration = hand_eye_from_args(args)
    T_base_flange = robot_pose_from_args(args)
    if calibration.mode is HandEyeMode.EYE_IN_HAND and T_base_flange is None:
        raise InputError(
            "--mode eye-in-hand needs the flange pose at capture time: give --robot-pose FILE "
            "or --robot-pose-ur X Y Z RX RY RZ"
        )
    if calibration.mode is HandEyeMode.EYE_TO_HAND and T_base_flange is not None:
        raise InputError(
            "--mode eye-to-hand uses no robot pose (the camera is fixed in the cell): drop "
            "--robot-pose/--robot-pose-ur, or use --mode eye-in-hand if the camera is on the arm"
        )
    return CameraChain(calibration, T_base_flange, calibration.T_base_cam(T_base_flange))


def measured_camera_from_args(args: argparse.Namespace, mode: HandEyeMode) -> MeasuredCamera | None:
    """``--camera-position-mm`` with its tolerance, checked; None when no position was given."""
    tolerance_mm = args.camera_position_tolerance_mm
    if args.camera_position_mm is None:
        if tolerance_mm is not None:
            raise InputError(
                "--camera-position-tolerance-mm applies to --camera-position-mm, which was not "
                "given"
            )
        return None
    x, y, z = args.camera_position_mm
    problem = measured_position_problem(mode, (x, y, z))
    if problem is not None:
        raise InputError(f"--camera-position-mm: {problem}")
    if tolerance_mm is None:
        return MeasuredCamera((x, y, z))
    if not 0.0 < tolerance_mm <= MAX_CAMERA_POSITION_TOLERANCE_MM:
        raise InputError(
            "--camera-position-tolerance-mm must be greater than 0 and at most "
            f"{MAX_CAMERA_POSITION_TOLERANCE_MM:g} mm, got {tolerance_mm:g}"
        )
    return MeasuredCamera((x, y, z), tolerance_mm)


def refuse_implausible_chain(
    args: argparse.Namespace, chain: CameraChain, T_cam_obj: Transform | None
) -> None:
    """Refuse (``InputError``) a chain that fails a plausibility check not given to
    ``--acknowledge``; an acknowledged failure is logged as a warning."""
    problems = chain_problems(
        chain.calibration,
        chain.T_base_flange,
        T_cam_obj,
        None,
        args.acknowledge,
        measured=measured_camera_from_args(args, chain.calibration.mode),
    )
    for problem in problems:
        if problem.acknowledged:
            log.warning("acknowledged %s: %s", problem.check, problem.message)
    refuse_implausible(problems, chain.calibration.settings, InputError)
