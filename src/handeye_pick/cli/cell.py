"""Command-line pieces shared by the commands that work on a configured cell: ``pick``, ``plan``,
``status`` and ``touch-test``.

Robot poses in JSON output are UR pose vectors (m, rad); the detection is in the camera frame.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from handeye_pick.calibration import HandEyeCalibration, load_hand_eye
from handeye_pick.cli.common import camera_point_mm_from_args
from handeye_pick.config import CellConfig
from handeye_pick.detection import Detection, detection_from_point_mm, load_detection
from handeye_pick.errors import InputError
from handeye_pick.geometry import ur_pose_list
from handeye_pick.pick import STEPS, PickPlan, target_of
from handeye_pick.progress import Progress


def add_config_arg(parser: argparse.ArgumentParser) -> None:
    """Add the required ``--config FILE``."""
    parser.add_argument(
        "--config", required=True, type=Path, metavar="FILE", help="cell configuration (YAML)"
    )


def add_detection_arg(parser: argparse.ArgumentParser) -> None:
    """Add ``--detection FILE``, the alternative to a camera point (see ``detection_from_args``)."""
    parser.add_argument(
        "--detection",
        type=Path,
        metavar="FILE",
        help="detection file: position_mm and an optional orientation, camera frame",
    )


def detection_from_args(args: argparse.Namespace) -> Detection:
    """The detection from ``--detection FILE`` or a camera point (``--xyz`` / ``--cloud``)."""
    point_mm = camera_point_mm_from_args(args)
    if args.detection is not None and point_mm is not None:
        raise InputError("pick: give either --detection FILE or a camera point, not both")
    if args.detection is not None:
        return load_detection(args.detection)
    if point_mm is None:
        raise InputError(
            "pick: no object given: use --detection FILE, --xyz X Y Z or --cloud FILE --pixel "
            "COL ROW"
        )
    source = "--xyz" if args.cloud is None else f"{args.cloud} pixel {args.pixel}"
    return detection_from_point_mm(point_mm, source)


def calibration_from_config(config: CellConfig) -> HandEyeCalibration:
    """The hand-eye calibration the cell configuration names (file, mode, units, inversion)."""
    hand_eye = config.hand_eye
    return load_hand_eye(hand_eye.file, hand_eye.mode, hand_eye.units, hand_eye.invert)


def progress_from_args(args: argparse.Namespace) -> Progress:
    """Progress lines on stderr, silent with ``--quiet`` or ``--json``."""
    return Progress(None if args.quiet or args.json else sys.stderr)


def plan_fields(plan: PickPlan) -> dict[str, object]:
    """The plan for a JSON report: poses as UR vectors, ``T_base_cam`` as a 4x4 (m)."""
    return {
        "flange_pose": ur_pose_list(plan.T_base_flange),
        "tcp_offset": ur_pose_list(plan.T_flange_tcp),
        "object_pose": ur_pose_list(plan.T_base_obj),
        "T_base_cam": plan.T_base_cam.tolist(),
        "targets": {name: ur_pose_list(target_of(plan.targets, name)) for name in STEPS},
    }


def print_json(report: dict[str, object]) -> None:
    """Print one JSON object on stdout."""
    print(json.dumps(report, indent=2), flush=True)
