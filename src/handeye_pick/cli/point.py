"""``point``: one camera-frame point (mm) into the robot base frame (mm), without a robot:
``p_base = T_base_cam @ p_cam``."""

from __future__ import annotations

import argparse

import numpy as np
from numpy.typing import NDArray

from handeye_pick.cli.common import (
    add_camera_point_args,
    add_hand_eye_args,
    add_robot_pose_args,
    camera_chain_from_args,
    camera_point_mm_from_args,
    refuse_implausible_chain,
)
from handeye_pick.cli.json_report import add_json_arg
from handeye_pick.detection import detection_from_point_mm
from handeye_pick.errors import InputError
from handeye_pick.geometry import (
    transform_point,
)


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the command to the top-level parser."""
    point = sub.add_parser(
        "point",
        help="transform one camera-frame point (mm) into the robot base frame (mm)",
        description="Transform one point from the camera frame to the robot base frame: "
        "p_base = T_base_cam @ p_cam. Eye-to-hand: T_base_cam is the calibration file. "
        "Eye-in-hand: T_base_cam = T_base_flange @ T_flange_cam, with T_base_flange the flange "
        "pose when the point was captured. Points in and out are mm; calibration and robot pose "
        "files are mm unless --calibration-units/--robot-pose-units m.",
    )
    add_hand_eye_args(point)
    add_robot_pose_args(point)
    add_camera_point_args(point)
    add_json_arg(point, "point_camera_mm, point_base_mm, T_base_cam_m, the calibration")
    point.set_defaults(run=run_point)


def run_point(args: argparse.Namespace) -> int:
    """Print the camera point in the robot base frame (mm)."""
    chain = camera_chain_from_args(args)
    p_cam_mm = camera_point_mm_from_args(args)
    if p_cam_mm is None:
        raise InputError("point needs --xyz X Y Z or --cloud FILE --pixel COL ROW")
    # The checks pick applies to a camera point (metres given as mm, behind the lens, ...).
    source = "--xyz" if args.cloud is None else f"{args.cloud} pixel {args.pixel}"
    detection = detection_from_point_mm(p_cam_mm, source)
    refuse_implausible_chain(args, chain, detection.T_cam_obj)
    p_base_mm = transform_point(chain.T_base_cam, p_cam_mm * 1e-3) * 1e3
    calibration = chain.calibration
    if args.json:
        args.report.update(
            mode=calibration.mode.value,
            calibration={
                "path": str(calibration.path),
                "sha256": calibration.sha256,
                "units": calibration.units,
                "inverted": calibration.inverted,
            },
            point_camera_mm=p_cam_mm.tolist(),
            point_base_mm=p_base_mm.tolist(),
            T_base_cam_m=chain.T_base_cam.tolist(),
            T_base_flange_m=None if chain.T_base_flange is None else chain.T_base_flange.tolist(),
        )
    else:
        print(f"point_camera_mm: {_numbers(p_cam_mm)}")
        print(f"point_base_mm:   {_numbers(p_base_mm)}")
    return 0


def _numbers(values: NDArray[np.float64]) -> str:
    return " ".join(f"{v:.4f}" for v in values)
