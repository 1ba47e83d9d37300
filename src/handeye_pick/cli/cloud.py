"""Command ``cloud``: a whole point cloud file from the camera frame to the robot base frame."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from handeye_pick.cli.common import (
    UNITS,
    add_hand_eye_args,
    add_robot_pose_args,
    camera_chain_from_args,
    refuse_implausible_chain,
)
from handeye_pick.cloud import transform_points
from handeye_pick.cloudio import cloud_file_type, read_cloud, write_cloud
from handeye_pick.geometry import metres_per, scale_translation


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``cloud`` command to the top-level parser."""
    parser = sub.add_parser(
        "cloud",
        help="transform a point cloud file from the camera frame into the robot base frame",
        description="Transform every point of a cloud file from the camera frame to the robot "
        "base frame: p_base = T_base_cam @ p_cam. Eye-to-hand: T_base_cam is the calibration "
        "file. Eye-in-hand: T_base_cam = T_base_flange @ T_flange_cam, with T_base_flange the "
        "flange pose when the cloud was captured. Points are mm (Zivid's unit) unless "
        "--cloud-units m; OUT keeps the unit, shape, dtype, colours and NaN (missing) points "
        "of IN.",
    )
    add_hand_eye_args(parser)
    add_robot_pose_args(parser)
    parser.add_argument(
        "--cloud-units",
        choices=UNITS,
        default="mm",
        help="length unit of the points in IN, and so of OUT (default: mm, Zivid's unit)",
    )
    parser.add_argument(
        "input",
        type=Path,
        metavar="IN",
        help="cloud in the camera frame: .npy (H x W x 3 or N x 3 float array) or .ply "
        "(ASCII or binary, as Zivid Studio and Open3D write it)",
    )
    parser.add_argument(
        "output",
        type=Path,
        metavar="OUT",
        help="where to write the cloud in the robot base frame: .npy or .ply (binary)",
    )
    parser.set_defaults(run=run_cloud)


def run_cloud(args: argparse.Namespace) -> int:
    """Read IN, transform it in place into the robot base frame, write OUT; print a summary."""
    chain = camera_chain_from_args(args)
    refuse_implausible_chain(args, chain, None)
    cloud_file_type(args.output, "write cloud")  # refuse a bad OUT before the slow part
    cloud = read_cloud(args.input)
    # The chain is in metres; the points stay in their own unit, so scale the translation.
    T_base_cam = scale_translation(chain.T_base_cam, 1.0 / metres_per(args.cloud_units))
    transform_points(cloud.xyz, T_base_cam, out=cloud.xyz)
    write_cloud(args.output, cloud)
    points = cloud.xyz.reshape(-1, 3)
    missing = int(np.count_nonzero(np.isnan(points).any(axis=1)))
    print(
        f"wrote {args.output}: {len(points)} points ({missing} without data), "
        f"robot base frame, {args.cloud_units}"
    )
    return 0
