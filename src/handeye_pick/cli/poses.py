"""``poses``: propose reachable poses that show the calibration board to the camera from varied
directions, checked by the controller (IK, safety limits) and the config (workspace, tilt);
writes a pose list (``calibration.pose_list``). Moves nothing; the robot side of a hand-eye
calibration starts here, ``collect`` visits the list.

Base-frame points on the command line are mm (like the workspace box); mounts are UR vectors
(m, rad) like every robot pose.
"""

from __future__ import annotations

import argparse
import itertools
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from handeye_pick.cli.cell import add_config_arg, progress_from_args
from handeye_pick.cli.common import accept_negative_exponents
from handeye_pick.cli.json_report import add_json_arg
from handeye_pick.config.schema import MAX_TCP_OFFSET_M
from handeye_pick.errors import InputError, SafetyRefusal
from handeye_pick.geometry import Transform, checked_ur_pose, rotation_angle_between, ur_pose_list
from handeye_pick.hand_eye.files import (
    EYE_IN_HAND_RANGE,
    EYE_TO_HAND_RANGE,
    HandEyeCalibration,
    HandEyeMode,
)

if TYPE_CHECKING:  # the cell's machinery loads when a command runs, not for --help
    from handeye_pick.cell.session import Cell

DEFAULT_COUNT = 10


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the command to the top-level parser."""
    poses = sub.add_parser(
        "poses",
        help="propose reachable poses for a hand-eye dataset; moves nothing",
        description="Propose COUNT poses that show the calibration board to the camera from "
        "varied directions (tilted up to 40 deg toward different sides, rolled; 30 deg or more "
        "between any two), keeping only targets the controller's IK and safety limits and the "
        "config's workspace box and tilt limit accept. Eye-in-hand: the camera looks at "
        "--look-at (the board's centre, board face up) from --distance-mm, tilted from straight "
        "down. Eye-to-hand: the board's centre is held at --look-at, its face turned toward the "
        "fixed camera, tilted from face on. Writes a pose list of TCP poses for "
        "robot.tcp_offset. The cell must be ready (the controller is asked about every target).",
    )
    accept_negative_exponents(poses)
    add_config_arg(poses)
    poses.add_argument(
        "--look-at",
        required=True,
        nargs=3,
        type=float,
        metavar=("X", "Y", "Z"),
        help="base frame, mm: the board's centre (eye-in-hand: where it lies; eye-to-hand: "
        "where the robot holds it)",
    )
    poses.add_argument(
        "--distance-mm",
        type=float,
        metavar="D",
        help="eye-in-hand (required): camera distance from the board's centre, mm. Eye-to-hand "
        "takes the distance from the camera's mount and refuses this flag",
    )
    poses.add_argument(
        "--count",
        type=int,
        default=DEFAULT_COUNT,
        metavar="N",
        help=f"number of poses (at least 4; 10 to 20 advised; default {DEFAULT_COUNT})",
    )
    poses.add_argument(
        "--out", required=True, type=Path, metavar="FILE", help="pose list to write (YAML)"
    )
    poses.add_argument(
        "--mount",
        nargs=6,
        type=float,
        metavar=("X", "Y", "Z", "RX", "RY", "RZ"),
        help="the camera's rough mount, UR vector (m, rad): T_flange_cam eye-in-hand, T_base_cam "
        "eye-to-hand (default: the cell's hand-eye file, which holds the same)",
    )
    poses.add_argument(
        "--board-mount",
        nargs=6,
        type=float,
        metavar=("X", "Y", "Z", "RX", "RY", "RZ"),
        help="eye-to-hand (required): the board's rough mount on the flange T_flange_obj, UR "
        "vector (m, rad); board frame: origin at its centre, z into the board",
    )
    add_json_arg(poses, "the pose list written and the TCP poses (UR vectors, m and rad)")
    poses.set_defaults(run=run_poses)


def run_poses(args: argparse.Namespace) -> int:
    """Propose, check with the controller, write the pose list; exit 0."""
    from handeye_pick.calibration.pose_list import write_pose_list
    from handeye_pick.cell.session import Cell

    cell = Cell(args.config, progress=progress_from_args(args))
    args.report.audit_from(cell)  # a failed connect is audited
    mode = cell.calibration.mode
    T_flange_obj = _mode_flags(args, mode)
    look_at_m = np.array(args.look_at, dtype=np.float64) / 1000.0
    T_mount = _mount(args, cell.calibration)
    T_flange_tcp = cell.config.robot.T_flange_tcp
    with cell:
        _require_ready(cell)
        with cell.progress.step("asking the controller about candidate poses"):
            flanges = _propose(cell, args, look_at_m, T_mount, T_flange_obj, T_flange_tcp)
    targets = [T @ T_flange_tcp for T in flanges]
    look_at = " ".join(f"{v:g}" for v in args.look_at)
    aim = (
        f"camera looks at [{look_at}] mm from {args.distance_mm:g} mm"
        if mode is HandEyeMode.EYE_IN_HAND
        else f"board centre held at [{look_at}] mm, turned toward the camera"
    )
    write_pose_list(
        args.out,
        targets,
        T_flange_tcp,
        [
            f"handeye-pick poses: {mode.value}, {aim}",
            f"for the cell {cell.config.path} (TCP poses for its robot.tcp_offset)",
        ],
    )
    separation_deg = _smallest_separation_deg(flanges)
    if args.json:
        args.report.update(
            out=str(args.out),
            mode=mode.value,
            poses=[ur_pose_list(T) for T in targets],
            smallest_separation_deg=separation_deg,
        )
        return 0
    lines = [f"{len(targets)} poses ({mode.value}, {aim}), TCP as UR vectors (m, rad):"]
    lines += [
        f"  pose {i:<3} [{', '.join(f'{v:.4f}' for v in ur_pose_list(T))}]"
        for i, T in enumerate(targets)
    ]
    lines.append(f"smallest rotation between two poses: {separation_deg:.1f} deg")
    lines.append(
        f"wrote {args.out}; next: handeye-pick collect --config {args.config} "
        f"--poses {args.out} --out DATASET"
    )
    print("\n".join(lines), flush=True)
    return 0


def _mode_flags(args: argparse.Namespace, mode: HandEyeMode) -> Transform | None:
    """The flags each mode needs and refuses (nothing given is silently ignored); eye-to-hand,
    the board's mount on the flange ``T_flange_obj`` (m), None eye-in-hand."""
    if mode is HandEyeMode.EYE_IN_HAND:
        if args.distance_mm is None:
            raise InputError("poses: eye-in-hand needs --distance-mm (camera to board centre)")
        if args.board_mount is not None:
            raise InputError(
                "poses: --board-mount is for eye-to-hand (the board on the flange); an "
                "eye-in-hand board lies in the cell at --look-at"
            )
        return None
    if args.distance_mm is not None:
        raise InputError(
            "poses: eye-to-hand takes the board's distance from the camera's mount to --look-at; "
            "drop --distance-mm"
        )
    if args.board_mount is None:
        raise InputError(
            "poses: eye-to-hand needs --board-mount X Y Z RX RY RZ, the board's rough pose on "
            "the flange (m, rad)"
        )
    return checked_ur_pose(
        args.board_mount,
        "--board-mount",
        max_m=MAX_TCP_OFFSET_M,
        distance="board distance from the flange",
    )


def _mount(args: argparse.Namespace, calibration: HandEyeCalibration) -> Transform:
    """The camera's rough mount (m): ``--mount`` (``T_flange_cam`` eye-in-hand, ``T_base_cam``
    eye-to-hand, checked like the hand-eye file of that mode) or the cell's hand-eye file."""
    if args.mount is None:
        return calibration.T_cal
    reach = EYE_IN_HAND_RANGE if calibration.mode is HandEyeMode.EYE_IN_HAND else EYE_TO_HAND_RANGE
    return reach.ur_pose(args.mount, "--mount")


def _require_ready(cell: Cell) -> None:
    """The controller answers for its active TCP: the cell must be ready, that TCP the config's."""
    state = cell.status()
    if not state.ready:
        raise SafetyRefusal(
            f"cell on {cell.config.robot.host} is not ready, poses cannot be checked: "
            + "; ".join(state.problems)
        )


def _propose(
    cell: Cell,
    args: argparse.Namespace,
    look_at_m: NDArray[np.float64],
    T_mount: Transform,
    T_flange_obj: Transform | None,
    T_flange_tcp: Transform,
) -> list[Transform]:
    """Flange poses from the mode's proposal (eye-to-hand when the board's mount
    ``T_flange_obj`` is given), each checked on the cell (as its TCP target)."""
    from handeye_pick.calibration.poses_eye_in_hand import propose_poses
    from handeye_pick.calibration.poses_eye_to_hand import propose_board_poses

    def feasible(T_base_flange: Transform) -> bool:
        return not cell.check_pose(T_base_flange @ T_flange_tcp)

    if T_flange_obj is None:
        return propose_poses(look_at_m, args.distance_mm / 1000.0, args.count, T_mount, feasible)
    return propose_board_poses(look_at_m, args.count, T_mount, T_flange_obj, feasible)


def _smallest_separation_deg(poses: list[Transform]) -> float:
    return min(
        math.degrees(rotation_angle_between(a[:3, :3], b[:3, :3]))
        for a, b in itertools.combinations(poses, 2)
    )
