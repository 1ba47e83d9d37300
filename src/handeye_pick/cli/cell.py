"""Command-line pieces shared by the commands that work on a configured cell: ``pick``, ``plan``,
``status``, ``touch-test`` and ``run``. They are clients of ``handeye_pick.cell.session.Cell``.

Robot poses in JSON output are UR pose vectors (m, rad); the detection is in the camera frame.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from handeye_pick.cli.common import accept_negative_exponents, camera_point_mm_from_args
from handeye_pick.detection import Detection, detection_from_point_mm, load_detection
from handeye_pick.errors import InputError
from handeye_pick.geometry import Transform, ur_pose_list
from handeye_pick.hand_eye.files import read_robot_pose_file, robot_pose_from_ur_vector
from handeye_pick.progress import Progress

if TYPE_CHECKING:
    from handeye_pick.cell.plan import PickPlan
    from handeye_pick.config.schema import CellConfig
    from handeye_pick.record.publisher import Publisher


def add_config_arg(parser: argparse.ArgumentParser) -> None:
    """Add the required ``--config FILE``."""
    parser.add_argument(
        "--config", required=True, type=Path, metavar="FILE", help="cell configuration (YAML)"
    )


def add_record_arg(parser: argparse.ArgumentParser) -> None:
    """Add ``--record PATH`` and ``--cloud-points N`` (docs/recording.md)."""
    parser.add_argument(
        "--record",
        type=Path,
        metavar="PATH",
        help="record the session as MCAP (Foxglove, Lichtblick): a new FILE, or a FOLDER that "
        "gets one file per hour and per 1 GiB",
    )
    parser.add_argument(
        "--cloud-points",
        type=int,
        default=50_000,
        metavar="N",
        help="most points of a recorded camera cloud, thinned evenly (default 50000)",
    )


def publisher_from_args(
    args: argparse.Namespace, config: CellConfig, live: tuple[str, int] | None = None
) -> Publisher | None:
    """The session's recording (``--record``) and live view (``live``), or None for neither;
    the recording's file is created here, before the robot is contacted."""
    if args.record is None and live is None:
        return None
    from handeye_pick.config.hand_eye import calibration_from_config
    from handeye_pick.record.publisher import Publisher
    from handeye_pick.record.recorder import check_record_path

    if args.cloud_points < 1:
        raise InputError(f"--cloud-points {args.cloud_points}: give at least 1")
    if args.record is not None:
        check_record_path(args.record)
    return Publisher(
        config,
        calibration_from_config(config),
        record=args.record,
        live=live,
        cloud_points=args.cloud_points,
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


def add_capture_pose_args(parser: argparse.ArgumentParser) -> None:
    """Add ``--capture-pose FILE | --capture-pose-ur X Y Z RX RY RZ``: the flange pose latched
    when the image was taken (eye-in-hand), instead of the live one."""
    accept_negative_exponents(parser)
    group = parser.add_argument_group(
        "flange pose at image acquisition (eye-in-hand): T_base_flange; without it the pick "
        "reads the live flange pose, which is right only if the arm has not moved since"
    )
    choice = group.add_mutually_exclusive_group()
    choice.add_argument(
        "--capture-pose",
        type=Path,
        metavar="FILE",
        help="4x4 flange pose file like Zivid's RobotTransform.yaml (mm)",
    )
    choice.add_argument(
        "--capture-pose-ur",
        nargs=6,
        type=float,
        metavar=("X", "Y", "Z", "RX", "RY", "RZ"),
        help="flange pose as a UR pose vector, metres and radians",
    )


def capture_pose_from_args(
    args: argparse.Namespace, detection: Detection
) -> tuple[Transform, str] | None:
    """The flange pose at acquisition and where it came from: a flag, or the detection file's
    ``capture`` section; None when neither gives one (the live pose is then used)."""
    flag: tuple[Transform, str] | None = None
    if args.capture_pose is not None:
        flag = read_robot_pose_file(args.capture_pose, units="mm"), str(args.capture_pose)
    elif args.capture_pose_ur is not None:
        source = "--capture-pose-ur"
        flag = robot_pose_from_ur_vector(args.capture_pose_ur, source), source
    if flag is not None and detection.T_base_flange_at_capture is not None:
        raise InputError(
            f"{detection.source} carries its capture pose already: drop --capture-pose/"
            "--capture-pose-ur, or the file's capture section"
        )
    if detection.T_base_flange_at_capture is not None:
        return detection.T_base_flange_at_capture, f"{detection.source} capture"
    return flag


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
        "targets": plan.targets_ur(),
    }


def show(value: object) -> str:
    """A value for a person: numbers to 4 places, yes/NO, - for nothing."""
    if isinstance(value, list):
        return "[" + ", ".join(f"{v:.4f}" for v in value) + "]"
    if isinstance(value, bool):
        return "yes" if value else "NO"
    return "-" if value is None else str(value)
