"""Rigid-transform maths on float64 4x4 matrices.

Conventions used across the package:

- ``T_a_b`` is the pose of frame ``b`` expressed in frame ``a``: ``p_a = T_a_b @ p_b``. Inner names
  cancel when chaining: ``T_base_obj = T_base_flange @ T_flange_cam @ T_cam_obj``.
- Translations inside the package are metres. Millimetres appear only at the edges (Zivid files,
  clouds, command-line points) and are converted where they are read or written.
- A UR pose vector is ``[x, y, z, rx, ry, rz]``: metres and a rotation vector in radians, exactly
  what the teach pendant and RTDE show.
"""

from __future__ import annotations

import warnings
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from handeye_pick.errors import TransformError

Transform = NDArray[np.float64]
"""A rigid transform: float64 array of shape (4, 4), bottom row [0, 0, 0, 1]."""

LengthUnit = Literal["mm", "m"]
AngleUnit = Literal["deg", "rad"]
QuaternionOrder = Literal["xyzw", "wxyz"]

METRES_PER_UNIT: dict[str, float] = {"m": 1.0, "mm": 1e-3}

ROTATION_TOLERANCE = 1e-5
"""Largest accepted |R^T R - I| entry and |det R - 1|.

Real tools write float32 matrices with 7 significant digits (errors near 1e-7); 1e-5 accepts
those and rejects a matrix that was scaled, sheared or typed in wrong.
"""


def metres_per(unit: str) -> float:
    """Scale from ``unit`` ("mm" or "m") to metres; anything else is an error."""
    try:
        return METRES_PER_UNIT[unit]
    except KeyError:
        raise TransformError(f"unknown length unit {unit!r}: expected 'mm' or 'm'") from None


def validate_rotation(R: ArrayLike, source: str) -> NDArray[np.float64]:
    """Return ``R`` as a float64 3x3 rotation matrix, or raise naming ``source`` and the defect."""
    arr = np.asarray(R, dtype=np.float64)
    if arr.shape != (3, 3):
        raise TransformError(f"{source}: rotation must be 3x3, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise TransformError(f"{source}: rotation has non-finite entries")
    ortho_err = float(np.max(np.abs(arr.T @ arr - np.eye(3))))
    if ortho_err > ROTATION_TOLERANCE:
        raise TransformError(
            f"{source}: rotation is not orthonormal (max |R^T R - I| = {ortho_err:.2e}, "
            f"tolerance {ROTATION_TOLERANCE:.0e})"
        )
    det = float(np.linalg.det(arr))
    if abs(det - 1.0) > ROTATION_TOLERANCE:
        raise TransformError(
            f"{source}: rotation has determinant {det:.6f}, expected +1 (a reflection?)"
        )
    return arr


def validate_transform(T: ArrayLike, source: str) -> Transform:
    """Return ``T`` as a float64 4x4 rigid transform, or raise naming ``source`` and the defect.

    Checks shape, finiteness, bottom row ``[0, 0, 0, 1]``, orthonormal rotation with det +1
    (within ``ROTATION_TOLERANCE``). The matrix is not repaired: a bad one is refused.
    """
    try:
        arr = np.array(T, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TransformError(f"{source}: not a numeric matrix ({exc})") from None
    if arr.shape != (4, 4):
        raise TransformError(f"{source}: transform must be 4x4, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise TransformError(f"{source}: transform has non-finite entries")
    if not np.array_equal(arr[3], [0.0, 0.0, 0.0, 1.0]):
        raise TransformError(f"{source}: bottom row must be [0, 0, 0, 1], got {arr[3].tolist()}")
    validate_rotation(arr[:3, :3], source)
    return arr


def make_transform(R: ArrayLike, t: ArrayLike) -> Transform:
    """Build ``T`` from a 3x3 rotation ``R`` and a translation ``t`` (3,), both float64."""
    T = np.eye(4)
    T[:3, :3] = np.asarray(R, dtype=np.float64)
    T[:3, 3] = np.asarray(t, dtype=np.float64)
    return T


def invert(T: Transform) -> Transform:
    """Closed-form inverse of a rigid transform: ``T_b_a`` from ``T_a_b``."""
    R = T[:3, :3]
    Ti = np.eye(4)
    Ti[:3, :3] = R.T
    Ti[:3, 3] = -R.T @ T[:3, 3]
    return Ti


def compose(*Ts: Transform) -> Transform:
    """Chain transforms left to right: ``compose(T_a_b, T_b_c) == T_a_c``."""
    out = np.eye(4)
    for T in Ts:
        out = out @ T
    return out


def scale_translation(T: Transform, metres_per_unit: float) -> Transform:
    """Return ``T`` with its translation multiplied by ``metres_per_unit`` (e.g. mm -> m: 1e-3)."""
    out: Transform = T.copy()
    out[:3, 3] *= metres_per_unit
    return out


def transform_point(T_a_b: Transform, p_b: ArrayLike) -> NDArray[np.float64]:
    """Map one point from frame b to frame a: ``p_a = R p_b + t`` (same length unit as T)."""
    p = np.asarray(p_b, dtype=np.float64)
    if p.shape != (3,):
        raise TransformError(f"point must have 3 coordinates, got shape {p.shape}")
    return T_a_b[:3, :3] @ p + T_a_b[:3, 3]


def rotation_angle_between(R1: ArrayLike, R2: ArrayLike) -> float:
    """Angle in radians of the relative rotation ``R1^T R2``; 0 when they are the same rotation."""
    Rrel = np.asarray(R1, dtype=np.float64).T @ np.asarray(R2, dtype=np.float64)
    cos = (np.trace(Rrel) - 1.0) / 2.0
    # arccos loses precision near 0; the sine from the skew part keeps small angles exact.
    skew = np.array([Rrel[2, 1] - Rrel[1, 2], Rrel[0, 2] - Rrel[2, 0], Rrel[1, 0] - Rrel[0, 1]])
    return float(np.arctan2(np.linalg.norm(skew) / 2.0, cos))


# --- UR pose vectors ---------------------------------------------------------------------------


def _vector(values: ArrayLike, length: int, what: str) -> NDArray[np.float64]:
    arr = np.asarray(values, dtype=np.float64)
    if arr.shape != (length,):
        raise TransformError(f"{what} must have {length} numbers, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise TransformError(f"{what} has non-finite values: {arr.tolist()}")
    return arr


def ur_pose_to_matrix(pose_m_rad: ArrayLike) -> Transform:
    """UR pose vector ``[x, y, z, rx, ry, rz]`` (m, rotation vector in rad) -> 4x4 transform (m)."""
    v = _vector(pose_m_rad, 6, "UR pose vector [x, y, z, rx, ry, rz]")
    return make_transform(Rotation.from_rotvec(v[3:]).as_matrix(), v[:3])


def matrix_to_ur_pose(T: Transform) -> NDArray[np.float64]:
    """4x4 transform (m) -> UR pose vector ``[x, y, z, rx, ry, rz]`` (m, rad, angle in [0, pi])."""
    out = np.empty(6)
    out[:3] = T[:3, 3]
    out[3:] = rotation_to_rotvec(T[:3, :3])
    return out


def ur_pose_list(T: Transform) -> list[float]:
    """``matrix_to_ur_pose`` as plain floats, for JSON and for ur_rtde calls (m, rad)."""
    return [float(v) for v in matrix_to_ur_pose(T)]


# --- orientation representations -----------------------------------------------------------------


def _scipy_rotation(R: ArrayLike, target: str) -> Rotation:
    # scipy's from_matrix silently repairs a non-rotation; refuse it first.
    return Rotation.from_matrix(validate_rotation(R, f"rotation to convert to {target}"))


def rotation_from_rotvec(rotvec_rad: ArrayLike) -> NDArray[np.float64]:
    """Rotation vector (axis times angle, rad) -> 3x3 rotation matrix."""
    return np.asarray(Rotation.from_rotvec(_vector(rotvec_rad, 3, "rotation vector")).as_matrix())


def rotation_to_rotvec(R: ArrayLike) -> NDArray[np.float64]:
    """3x3 rotation matrix -> rotation vector (rad), angle in [0, pi]; exact near pi and zero."""
    return np.asarray(_scipy_rotation(R, "rotation vector").as_rotvec())


def rotation_from_quaternion(q: ArrayLike, order: QuaternionOrder) -> NDArray[np.float64]:
    """Unit quaternion in the named component order -> 3x3 rotation matrix.

    The norm must be 1 within 1e-3: a quaternion far from unit length is a sign of a wrong
    order or a wrong field, not something to normalise away.
    """
    v = _vector(q, 4, f"quaternion ({order})")
    if order == "wxyz":
        v = np.roll(v, -1)
    elif order != "xyzw":
        raise TransformError(f"unknown quaternion order {order!r}: expected 'xyzw' or 'wxyz'")
    norm = float(np.linalg.norm(v))
    if abs(norm - 1.0) > 1e-3:
        raise TransformError(f"quaternion ({order}) must have unit norm, got {norm:.6f}")
    return np.asarray(Rotation.from_quat(v / norm).as_matrix())


def rotation_to_quaternion(R: ArrayLike, order: QuaternionOrder) -> NDArray[np.float64]:
    """3x3 rotation matrix -> unit quaternion in the named order, with w >= 0."""
    q = np.asarray(_scipy_rotation(R, f"quaternion ({order})").as_quat(canonical=True))
    if order == "wxyz":
        return np.roll(q, 1)
    if order != "xyzw":
        raise TransformError(f"unknown quaternion order {order!r}: expected 'xyzw' or 'wxyz'")
    return q


def check_euler_sequence(sequence: str) -> str:
    """Validate an Euler sequence as scipy names it: 'xyz' (extrinsic) or 'XYZ' (intrinsic)."""
    ok = (
        len(sequence) == 3
        and (sequence.islower() or sequence.isupper())
        and set(sequence.lower()) <= {"x", "y", "z"}
        and sequence[0] != sequence[1]
        and sequence[1] != sequence[2]
    )
    if not ok:
        raise TransformError(
            f"Euler sequence {sequence!r} is not valid: use three axes from x, y, z, all lower "
            "case (extrinsic, e.g. 'xyz') or all upper case (intrinsic, e.g. 'ZYX')"
        )
    return sequence


def _check_angle_unit(unit: str) -> bool:
    if unit not in ("deg", "rad"):
        raise TransformError(f"unknown angle unit {unit!r}: expected 'deg' or 'rad'")
    return unit == "deg"


def rotation_from_euler(angles: ArrayLike, sequence: str, unit: AngleUnit) -> NDArray[np.float64]:
    """Euler / roll-pitch-yaw angles with an explicit sequence and angle unit -> 3x3 rotation."""
    degrees = _check_angle_unit(unit)
    v = _vector(angles, 3, f"Euler angles ({sequence}, {unit})")
    R = Rotation.from_euler(check_euler_sequence(sequence), v, degrees=degrees)
    return np.asarray(R.as_matrix())


def rotation_to_euler(R: ArrayLike, sequence: str, unit: AngleUnit) -> NDArray[np.float64]:
    """3x3 rotation -> Euler angles in the named sequence and unit.

    At gimbal lock (middle angle within ~1e-7 rad of its singular value) only the sum or
    difference of the outer angles is defined: the third angle is set to 0, as scipy does, and
    the angles still give back the rotation within 1e-6 rad.
    """
    degrees = _check_angle_unit(unit)
    rot = _scipy_rotation(R, f"Euler angles ({sequence}, {unit})")
    with warnings.catch_warnings():
        # The documented gimbal-lock choice above is not news to the caller.
        warnings.filterwarnings("ignore", message="Gimbal lock detected", category=UserWarning)
        return np.asarray(rot.as_euler(check_euler_sequence(sequence), degrees=degrees))
