"""Command ``calibrate``: a hand-eye calibration from a dataset of numbered pose pairs."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

from handeye_pick.calibration.dataset import read_dataset
from handeye_pick.calibration.report import (
    TRANSFORM_NAMES,
    result_record,
    result_table,
    write_residuals,
)
from handeye_pick.calibration.solver import MIN_PAIRS, MeasurementNoise, solve_hand_eye
from handeye_pick.cli.common import UNITS
from handeye_pick.cli.json_report import add_json_arg
from handeye_pick.errors import InputError
from handeye_pick.hand_eye.files import HandEyeMode, write_zivid_transform

log = logging.getLogger(__name__)

RESULT_NAME = "hand_eye_transform.yaml"
RESIDUALS_NAME = "hand_eye_residuals.yaml"


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``calibrate`` command to the top-level parser."""
    defaults = MeasurementNoise()
    parser = sub.add_parser(
        "calibrate",
        help="solve a hand-eye calibration from robot_pose_N.yaml / object_pose_N.yaml pairs",
        description="Solve the hand-eye calibration from DATASET, a folder of pairs "
        "robot_pose_N.yaml (T_base_flange, the flange pose in the robot base frame) and "
        "object_pose_N.yaml (T_cam_obj, the calibration object's pose in the camera frame), in "
        "Zivid's matrix YAML or the legacy OpenCV YAML, mm. Eye-in-hand solves T_flange_cam, "
        "eye-to-hand T_base_cam. OpenCV's calibrateHandEye methods give the starts; a "
        "least-squares fit over every pair, weighted by the stated measurement noise, gives the "
        "result. Prints the residual of every pair N (mm, deg) and names suspects; nothing is "
        f"excluded unless --exclude says so. Refuses fewer than {MIN_PAIRS} pairs and "
        "degenerate motion (exit 2).",
    )
    parser.add_argument(
        "--mode",
        required=True,
        choices=[m.value for m in HandEyeMode],
        help="eye-in-hand: camera on the flange, object fixed, solves T_flange_cam; "
        "eye-to-hand: camera fixed, object on the flange, solves T_base_cam",
    )
    parser.add_argument("dataset", type=Path, metavar="DATASET", help="the folder of pairs")
    parser.add_argument(
        "--out",
        type=Path,
        metavar="FILE",
        help=f"where to write the result in Zivid's format, mm (default: DATASET/{RESULT_NAME}); "
        f"{RESIDUALS_NAME} is written beside it",
    )
    parser.add_argument(
        "--exclude",
        type=_pair_numbers,
        default=(),
        metavar="N,N",
        help="pair numbers to leave out, e.g. 3,7 (the N of the file names)",
    )
    parser.add_argument(
        "--units",
        choices=UNITS,
        default="mm",
        help="translation unit of every pose file in DATASET (default: mm, Zivid's unit)",
    )
    parser.add_argument(
        "--camera-noise",
        nargs=3,
        type=float,
        metavar=("LATERAL_MM", "DEPTH_MM", "ROT_DEG"),
        default=(
            defaults.camera_lateral_mm,
            defaults.camera_depth_mm,
            defaults.camera_rotation_deg,
        ),
        help="one standard deviation of the object pose the camera measures: across the view, "
        "along the optical axis, rotation (default: %(default)s)",
    )
    parser.add_argument(
        "--robot-noise",
        nargs=2,
        type=float,
        metavar=("MM", "DEG"),
        default=(defaults.robot_translation_mm, defaults.robot_rotation_deg),
        help="one standard deviation of the flange pose the robot reports (default: %(default)s)",
    )
    add_json_arg(parser, "the transform (m), residuals, suspects, start method, warnings")
    parser.set_defaults(run=run_calibrate)


def run_calibrate(args: argparse.Namespace) -> int:
    """Solve, write the result and the residuals, print the table (or JSON)."""
    noise = MeasurementNoise(*args.camera_noise, *args.robot_noise)
    pairs = read_dataset(args.dataset, args.units, "--units")
    result = solve_hand_eye(pairs, HandEyeMode(args.mode), exclude=set(args.exclude), noise=noise)
    out = args.out if args.out is not None else args.dataset / RESULT_NAME
    residuals = out.parent / RESIDUALS_NAME
    write_zivid_transform(out, result.fit.T_cal, "mm")
    write_residuals(residuals, result)
    for warning in result.warnings:
        log.warning("%s", warning)
    if args.json:
        args.report.update(**result_record(result), out=str(out), residuals_file=str(residuals))
    else:
        print(result_table(result))
        print(f"wrote {out} ({TRANSFORM_NAMES[result.mode]}, mm) and {residuals}")
    return 0


def _pair_numbers(text: str) -> tuple[int, ...]:
    """``3,7`` -> (3, 7); anything else is an error naming the bad part."""
    numbers = []
    for part in text.split(","):
        try:
            number = int(part.strip())
        except ValueError:
            raise InputError(
                f"--exclude takes pair numbers separated by commas, e.g. 3,7; got {text!r}"
            ) from None
        if number < 0:
            raise InputError(f"--exclude: pair numbers are >= 0, got {number}")
        numbers.append(number)
    return tuple(numbers)
