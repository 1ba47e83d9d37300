"""A detected object in the camera frame: from a detection file or a single camera point.

Frames and units: ``T_cam_obj`` is the object pose in the camera's optical frame (z forward,
out of the lens), in metres. Files and command-line points give millimetres.

Detection file (YAML)::

    position_mm: [83.95, 28.84, 305.7]
    orientation:                  # optional; absent means position only. Exactly one of:
      rotvec_rad: [0, 0, 0]       #   rotation vector (axis * angle), rad
      # quaternion_xyzw: [0, 0, 0, 1]
      # quaternion_wxyz: [1, 0, 0, 0]
      # rpy_deg: {angles: [0, 0, 0], convention: xyz}   # scipy: xyz extrinsic, XYZ intrinsic
      # matrix: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]       # 3x3 rotation, validated
    size_mm: [80, 60, 50]         # optional; the part's box in the object frame (x, y, z), mm
    symmetry: {axis: z, order: 4} # optional; the part looks the same turned 360/order deg
                                  # about that object axis (order 2, 3, 4, 6 or inf)
    capture:                      # optional; eye-in-hand: the flange pose at image acquisition
      flange_pose_ur: [x, y, z, rx, ry, rz]   # T_base_flange as a UR vector, m and rad
      # robot_pose_file: RobotTransform.yaml  # or Zivid's 4x4 file (mm), relative to this file

The run loop's candidates are the same mapping as JSON, without ``capture`` (a request names
its capture by id).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from handeye_pick.config.reader import Fields, part_size_mm, read_yaml_mapping
from handeye_pick.errors import DetectionError, TransformError
from handeye_pick.geometry import (
    Transform,
    checked_rotvec,
    make_transform,
    rotation_from_euler,
    rotation_from_quaternion,
    rotation_from_rotvec,
    validate_rotation,
)
from handeye_pick.hand_eye.files import read_robot_pose_file, robot_pose_from_ur_vector

# A point closer than 10 mm to the camera is no detection: it is metres typed as millimetres
# (0.3 "mm" instead of 300 mm). Farther than 10 m is beyond any 3D camera used for picking.
MIN_DISTANCE_MM = 10.0
MAX_DISTANCE_MM = 10_000.0

ORIENTATION_KEYS = ("rotvec_rad", "quaternion_xyzw", "quaternion_wxyz", "rpy_deg", "matrix")
CAPTURE_KEYS = ("flange_pose_ur", "robot_pose_file")

# Bounds on orientation numbers, checked before any arithmetic (which overflows near 1e308).
# Quaternion and matrix entries: far beyond any rotation's (+-1), so a near miss still gets the
# specific message (unit norm, orthonormal). Euler angles: beyond a full turn is a wrong unit.
# Rotation vectors: geometry.checked_rotvec, the one reader of rotation vectors from outside.
MAX_ROTATION_ENTRY = 1e6
MAX_EULER_DEG = 360.0
SYMMETRY_ORDERS = ("2", "3", "4", "6", "inf")


@dataclass(frozen=True)
class Symmetry:
    """The part looks the same turned by every multiple of 360/``order`` degrees about its
    object frame's ``axis``; ``order`` 0 stands for any angle (``inf``)."""

    axis: str  # x, y or z of the object frame
    order: int  # 2, 3, 4, 6, or 0 for inf


@dataclass(frozen=True)
class Detection:
    """An object pose in the camera frame.

    ``T_cam_obj`` in metres. With ``position_only`` the rotation is identity and means nothing:
    the grasp keeps the tool pointing down instead of following it.
    """

    T_cam_obj: Transform
    position_only: bool
    source: str  # where it came from, for messages and the audit record
    T_base_flange_at_capture: Transform | None = None  # from the file's capture section (m)
    # The part's box in the object frame (mm): x and y centred on the origin, from 0 to z along
    # +z, the way the tool points into it (docs/scene.md); None: not given
    size_mm: tuple[float, float, float] | None = None
    symmetry: Symmetry | None = None


def _check_point_mm(p_cam_mm: NDArray[np.float64], source: str) -> None:
    """Refuse a camera point that cannot be a detection: non-finite, behind, at or far from the
    lens."""
    if not np.all(np.isfinite(p_cam_mm)):
        raise DetectionError(f"{source}: camera point has non-finite values {p_cam_mm.tolist()}")
    distance = math.hypot(*p_cam_mm.tolist())  # no overflow (and no numpy warning) at 1e308
    if not MIN_DISTANCE_MM <= distance <= MAX_DISTANCE_MM:
        hint = " (metres given as mm?)" if distance < MIN_DISTANCE_MM else ""
        raise DetectionError(
            f"{source}: camera point {p_cam_mm.tolist()} mm is {distance:g} mm from the camera, "
            f"expected {MIN_DISTANCE_MM:g} to {MAX_DISTANCE_MM:g} mm{hint}"
        )
    if p_cam_mm[2] <= 0.0:
        raise DetectionError(
            f"{source}: camera point {p_cam_mm.tolist()} mm has z <= 0, behind the camera "
            "(camera frame: z points out of the lens)"
        )


def detection_from_point_mm(p_cam_mm: ArrayLike, source: str) -> Detection:
    """A position-only detection from one camera-frame point in millimetres (``--xyz``, a pixel
    of a cloud)."""
    p = np.asarray(p_cam_mm, dtype=np.float64)
    if p.shape != (3,):
        raise DetectionError(f"{source}: camera point must have 3 coordinates, got shape {p.shape}")
    _check_point_mm(p, source)
    return Detection(
        T_cam_obj=make_transform(np.eye(3), p / 1000.0), position_only=True, source=source
    )


def _rotation(orientation: Fields) -> NDArray[np.float64]:
    """The one rotation given in an ``orientation`` mapping, as a validated 3x3."""
    given = [key for key in ORIENTATION_KEYS if orientation.has(key)]
    if len(given) != 1:
        orientation.fail(
            "", f"give exactly one of {', '.join(ORIENTATION_KEYS)}; got {given or 'none'}"
        )
    key = given[0]
    try:
        if key == "rotvec_rad":  # the rotation part of the UR pose reader
            return rotation_from_rotvec(checked_rotvec(orientation.vector(key, 3)))
        if key in ("quaternion_xyzw", "quaternion_wxyz"):
            q = _bounded(orientation, key, orientation.vector(key, 4), MAX_ROTATION_ENTRY)
            return rotation_from_quaternion(q, "xyzw" if key == "quaternion_xyzw" else "wxyz")
        if key == "rpy_deg":
            rpy = orientation.section(key, ("angles", "convention"))
            angles = _bounded(rpy, "angles", rpy.vector("angles", 3), MAX_EULER_DEG)
            return rotation_from_euler(angles, rpy.string("convention"), "deg")
        matrix = _bounded(orientation, key, orientation.matrix(key, 3, 3), MAX_ROTATION_ENTRY)
        return validate_rotation(matrix, orientation.path(key))
    except TransformError as exc:
        orientation.fail(key, str(exc))


def _bounded(
    fields: Fields, key: str, values: NDArray[np.float64], limit: float
) -> NDArray[np.float64]:
    """``values`` if every magnitude is at most ``limit``, else an error naming the key."""
    largest = float(np.max(np.abs(values)))
    if largest > limit:
        fields.fail(key, f"{largest:g} is out of range: every value must lie within +-{limit:g}")
    return values


def load_detection(path: Path) -> Detection:
    """Read a detection file (format in the module docstring); errors name the file and key."""
    path = Path(path)
    data = read_yaml_mapping(path, DetectionError, "detection file")
    return detection_from_data(data, str(path), capture_folder=path.parent)


def detection_from_data(data: object, source: str, capture_folder: Path | None = None) -> Detection:
    """A detection from parsed YAML/JSON data (``position_mm``, optional ``orientation``).

    ``capture`` (the flange pose at acquisition) is accepted only with ``capture_folder``, the
    folder its ``robot_pose_file`` is relative to: files carry it, run-loop requests do not.
    """
    allowed = ("position_mm", "orientation", "size_mm", "symmetry") + (
        ("capture",) if capture_folder else ()
    )
    top = Fields(data, source=source, prefix="", allowed=allowed, error=DetectionError)
    p_mm = top.vector("position_mm", 3)
    _check_point_mm(p_mm, f"{source}: position_mm")
    position_only = not top.has("orientation")
    R = np.eye(3) if position_only else _rotation(top.section("orientation", ORIENTATION_KEYS))
    T_base_flange = None
    if capture_folder is not None and top.has("capture"):
        T_base_flange = _capture_pose(top.section("capture", CAPTURE_KEYS), capture_folder)
    return Detection(
        make_transform(R, p_mm / 1000.0),
        position_only,
        source,
        T_base_flange,
        size_mm=part_size_mm(top, "size_mm") if top.has("size_mm") else None,
        symmetry=_symmetry(top) if top.has("symmetry") else None,
    )


def _symmetry(top: Fields) -> Symmetry:
    symmetry = top.section("symmetry", ("axis", "order"))
    order = symmetry.raw("order")
    if isinstance(order, bool) or str(order) not in SYMMETRY_ORDERS:
        symmetry.fail("order", f"expected one of {', '.join(SYMMETRY_ORDERS)}, got {order!r}")
    return Symmetry(
        axis=symmetry.string("axis", choices=("x", "y", "z")),
        order=0 if str(order) == "inf" else int(str(order)),
    )


def _capture_pose(capture: Fields, folder: Path) -> Transform:
    """``T_base_flange`` (m) from exactly one of ``flange_pose_ur`` or ``robot_pose_file``."""
    given = [key for key in CAPTURE_KEYS if capture.has(key)]
    if len(given) != 1:
        capture.fail("", f"give exactly one of {', '.join(CAPTURE_KEYS)}; got {given or 'none'}")
    if given[0] == "flange_pose_ur":
        pose = capture.vector("flange_pose_ur", 6)
        try:  # the reader of --robot-pose-ur and --capture-pose-ur: m and rad checked
            return robot_pose_from_ur_vector(pose, "the flange pose")
        except TransformError as exc:
            capture.fail("flange_pose_ur", str(exc))
    return read_robot_pose_file(folder / capture.string("robot_pose_file"), units="mm")
