"""Command line of the simulated camera, run from the repository root.

    python -m mocks.camera object-pose --host H --mode eye-in-hand --camera X Y Z RX RY RZ
        --board X Y Z RX RY RZ [--model ur5e] [--noise-mm 0.1] [--noise-deg 0.02]
        [--axial-factor 3] [--seed 0] [--width 160 --height 120 --hfov-deg 60] [--out FILE]

``object-pose`` is a capture program for ``handeye-pick collect --capture-command``: it reads the
simulated arm's joints over RTDE, computes where the calibration board appears in the camera and
writes ``T_cam_obj`` (mm) in Zivid's matrix YAML to ``--out`` or, without it, to the file named by
``HANDEYE_OBJECT_POSE_FILE``. Poses are UR vectors (m, rad): ``--camera`` is ``T_flange_cam``
(eye-in-hand) or ``T_base_cam`` (eye-to-hand), ``--board`` is ``T_base_board`` (eye-in-hand: the
board lies in the cell) or ``T_flange_board`` (eye-to-hand: the robot carries it). The noise is
seeded with ``--seed`` and ``HANDEYE_POSE_INDEX`` (0 when unset), so every pose of a collection
gets its own, reproducible draw.

Exit status: 0 written; 2 bad arguments; 3 the board is not visible (nothing written);
4 the robot could not be read (nothing written).
"""

from __future__ import annotations

import argparse
import os
import sys

from mocks.camera.board import BoardNotVisible, CalibrationBoard, PoseNoise
from mocks.camera.camera import Intrinsics, SimulatedCamera
from mocks.camera.robot_pose import read_flange_pose
from mocks.camera.scene import Scene
from mocks.camera.zivid_yaml import write_zivid_matrix
from mocks.ur_controller.kinematics import MODELS, pose_to_matrix

OUT_ENV = "HANDEYE_OBJECT_POSE_FILE"
INDEX_ENV = "HANDEYE_POSE_INDEX"
EXIT_NOT_VISIBLE = 3
EXIT_NO_ROBOT = 4


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m mocks.camera",
                                     description="Simulated 3D camera.")
    commands = parser.add_subparsers(dest="command", required=True)
    pose = commands.add_parser(
        "object-pose", help="write the calibration board's pose T_cam_obj (mm, Zivid YAML)")
    pose.add_argument("--host", required=True, help="the simulated controller's address")
    pose.add_argument("--model", default="ur5e", choices=sorted(MODELS),
                      help="robot model, as the controller's --model")
    pose.add_argument("--mode", required=True, choices=("eye-in-hand", "eye-to-hand"))
    pose.add_argument("--camera", required=True, nargs=6, type=float, metavar="V",
                      help="true T_flange_cam (eye-in-hand) or T_base_cam (eye-to-hand), m, rad")
    pose.add_argument("--board", required=True, nargs=6, type=float, metavar="V",
                      help="T_base_board (eye-in-hand) or T_flange_board (eye-to-hand), m, rad")
    pose.add_argument("--noise-mm", type=float, default=0.1,
                      help="translation noise across the optical axis, std per axis (mm)")
    pose.add_argument("--noise-deg", type=float, default=0.02,
                      help="rotation noise, std per axis (deg)")
    pose.add_argument("--axial-factor", type=float, default=3.0,
                      help="translation noise along the optical axis = this x --noise-mm")
    pose.add_argument("--seed", type=int, default=0,
                      help=f"noise seed, combined with ${INDEX_ENV}")
    pose.add_argument("--width", type=int, default=160, help="image width (px)")
    pose.add_argument("--height", type=int, default=120, help="image height (px)")
    pose.add_argument("--hfov-deg", type=float, default=60.0, help="horizontal field of view")
    pose.add_argument("--out", help=f"output file (default: ${OUT_ENV})")
    return parser


def object_pose(args: argparse.Namespace) -> int:
    out = args.out or os.environ.get(OUT_ENV)
    if not out:
        print(f"error: give --out or set {OUT_ENV}", file=sys.stderr)
        return 2
    index = int(os.environ.get(INDEX_ENV, "0"))
    mount = pose_to_matrix(args.camera)
    T_board = pose_to_matrix(args.board)
    eye_in_hand = args.mode == "eye-in-hand"
    camera = SimulatedCamera(
        Scene(),
        Intrinsics.from_fov(args.width, args.height, args.hfov_deg),
        T_flange_cam=mount if eye_in_hand else None,
        T_base_cam=None if eye_in_hand else mount,
        pose_noise=PoseNoise(args.noise_mm, args.noise_deg, args.axial_factor),
        seed=(args.seed, index),
    )
    board = CalibrationBoard.in_cell(T_board) if eye_in_hand \
        else CalibrationBoard.on_flange(T_board)
    try:
        T_base_flange = read_flange_pose(args.host, args.model)
    except OSError as exc:
        print(f"error: cannot read the robot's pose from {args.host}: {exc}", file=sys.stderr)
        return EXIT_NO_ROBOT
    try:
        T_cam_obj_mm = camera.object_pose_mm(board, T_base_flange)
    except BoardNotVisible as exc:
        print(f"error: no board found: {exc}", file=sys.stderr)
        return EXIT_NOT_VISIBLE
    write_zivid_matrix(out, T_cam_obj_mm)
    print(f"wrote T_cam_obj to {out}", file=sys.stderr)
    return 0


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return object_pose(args)
    except ValueError as exc:  # a bad pose, noise or image size given on the command line
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
