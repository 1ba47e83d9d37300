"""``convert``: one pose between UR vector, 4x4 matrix, quaternion and Euler/RPY."""

from __future__ import annotations

import argparse
import math

import numpy as np
from numpy.typing import NDArray

from handeye_pick.cli.common import (
    accept_negative_exponents,
)
from handeye_pick.cli.json_report import add_json_arg
from handeye_pick.errors import InputError
from handeye_pick.geometry import (
    AngleUnit,
    Transform,
    checked_ur_pose,
    make_transform,
    matrix_to_ur_pose,
    rotation_from_euler,
    rotation_from_quaternion,
    rotation_to_euler,
    rotation_to_quaternion,
    validate_transform,
)

_COUNTS = {"ur": 6, "matrix": 16, "quat-xyzw": 7, "quat-wxyz": 7, "euler": 6}
_FORMATS = tuple(_COUNTS)


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the command to the top-level parser."""
    convert = sub.add_parser(
        "convert",
        help="convert a pose between UR vector, 4x4 matrix, quaternion and Euler/RPY",
        description="Convert one pose between representations. Formats and their numbers: "
        "ur: X Y Z RX RY RZ (rotation vector, rad; UR pendant and RTDE); "
        "matrix: 16 numbers, 4x4 row-major; "
        "quat-xyzw: X Y Z QX QY QZ QW; quat-wxyz: X Y Z QW QX QY QZ; "
        "euler: X Y Z A B C with --sequence and --angle-unit (the UR pendant's RPY is "
        "--sequence xyz --angle-unit rad). The translation is copied unchanged, in the unit "
        "it was given (UR vectors: m).",
    )
    convert.add_argument("--from", dest="source", required=True, choices=_FORMATS, help="input")
    convert.add_argument("--to", dest="target", required=True, choices=_FORMATS, help="output")
    convert.add_argument(
        "--sequence",
        help="Euler axes as scipy names them: lower case extrinsic (xyz = roll, pitch, yaw "
        "about fixed axes), upper case intrinsic (ZYX)",
    )
    convert.add_argument("--angle-unit", choices=("deg", "rad"), help="Euler angle unit")
    add_json_arg(convert, "format and values (and the Euler sequence and angle unit)")
    convert.add_argument("values", nargs="+", type=float, metavar="NUMBER", help="the pose")
    accept_negative_exponents(convert)
    convert.set_defaults(run=run_convert)


def run_convert(args: argparse.Namespace) -> int:
    """Print the pose in the ``--to`` representation."""
    uses_euler = "euler" in (args.source, args.target)
    if args.source == "euler" and args.target == "euler":
        raise InputError(
            "convert: --from euler --to euler would use one --sequence for both sides; "
            "convert to matrix first, then from matrix"
        )
    if uses_euler and (args.sequence is None or args.angle_unit is None):
        raise InputError("convert: euler needs both --sequence (e.g. xyz or ZYX) and --angle-unit")
    if not uses_euler and (args.sequence is not None or args.angle_unit is not None):
        raise InputError("convert: --sequence and --angle-unit apply only to --from/--to euler")
    expected = _COUNTS[args.source]
    if len(args.values) != expected:
        raise InputError(
            f"convert --from {args.source}: expected {expected} numbers, got {len(args.values)}"
        )
    T = _to_matrix(args.source, np.array(args.values), args.sequence, args.angle_unit)
    values = _from_matrix(args.target, T, args.sequence, args.angle_unit)
    if args.json:
        args.report.update(format=args.target, values=values.tolist())
        if args.target == "euler":
            args.report.update(sequence=args.sequence, angle_unit=args.angle_unit)
    elif args.target == "matrix":
        for row in values:
            print(" ".join(f"{v: .12g}" for v in row))
    else:
        print(" ".join(f"{v:.12g}" for v in values))
    return 0


def _to_matrix(
    fmt: str, v: NDArray[np.float64], sequence: str | None, angle_unit: AngleUnit | None
) -> Transform:
    if fmt == "ur":  # the translation in any unit: only the rotation vector is checked
        return checked_ur_pose(v, "convert --from ur", max_m=math.inf)
    if fmt == "matrix":
        return validate_transform(v.reshape(4, 4), "convert --from matrix")
    if fmt == "quat-xyzw":
        return make_transform(rotation_from_quaternion(v[3:], "xyzw"), v[:3])
    if fmt == "quat-wxyz":
        return make_transform(rotation_from_quaternion(v[3:], "wxyz"), v[:3])
    if sequence is None or angle_unit is None:  # run_convert checked; narrows the types
        raise InputError("convert: euler needs --sequence and --angle-unit")
    return make_transform(rotation_from_euler(v[3:], sequence, angle_unit), v[:3])


def _from_matrix(
    fmt: str, T: Transform, sequence: str | None, angle_unit: AngleUnit | None
) -> NDArray[np.float64]:
    if fmt == "ur":
        return matrix_to_ur_pose(T)
    if fmt == "matrix":
        return T
    R, t = T[:3, :3], T[:3, 3]
    if fmt == "quat-xyzw":
        return np.concatenate([t, rotation_to_quaternion(R, "xyzw")])
    if fmt == "quat-wxyz":
        return np.concatenate([t, rotation_to_quaternion(R, "wxyz")])
    if sequence is None or angle_unit is None:
        raise InputError("convert: euler needs --sequence and --angle-unit")
    return np.concatenate([t, rotation_to_euler(R, sequence, angle_unit)])
