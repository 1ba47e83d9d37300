"""Rigid-transform maths on float64 4x4 matrices.

Conventions used across the package:

- ``T_a_b`` is the pose of frame ``b`` expressed in frame ``a``: ``p_a = T_a_b @ p_b``. Inner names
  cancel when chaining: ``T_base_obj = T_base_flange @ T_flange_cam @ T_cam_obj``.
- Translations inside the package are metres. Millimetres appear only at the edges (Zivid files,
  clouds, command-line points) and are converted where they are read or written.
- A UR pose vector is ``[x, y, z, rx, ry, rz]``: metres and a rotation vector in radians, exactly
  what the teach pendant and RTDE show.

Rotation conversions are closed forms in numpy, not scipy's ``Rotation``: importing
``scipy.spatial`` takes about 0.4 to 0.9 s (it pulls in ``scipy.sparse`` and ``scipy.linalg``),
more than everything else a command like ``convert`` or ``point`` does.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

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
    """UR pose vector ``[x, y, z, rx, ry, rz]`` (m, rotation vector in rad) -> 4x4 transform (m).

    For poses the controller reports. A pose from outside (a flag, a file, a request, a config
    key) is read with ``checked_ur_pose``, which refuses the unit mix-ups first."""
    v = _vector(pose_m_rad, 6, "UR pose vector [x, y, z, rx, ry, rz]")
    return make_transform(rotation_from_rotvec(v[3:]), v[:3])


MAX_ROTVEC_RAD = 2.0 * math.pi
"""Longest rotation vector accepted from outside (rad): a longer one can only be degrees."""


def checked_ur_pose(
    pose_m_rad: ArrayLike,
    source: str | None = None,
    *,
    max_m: float,
    min_m: float = 0.0,
    distance: str = "translation",
) -> Transform:
    """The one reader of a UR pose vector ``[x, y, z, rx, ry, rz]`` (m, rad) given from outside
    -> 4x4 transform (m).

    Refused (``TransformError``, one line starting with ``source`` when given): not 6 finite
    numbers; a translation shorter than ``min_m`` or longer than ``max_m`` (m; ``distance``
    names it, e.g. "flange distance from the robot base"), which millimetres make (the message
    then gives it in metres); a rotation vector longer than 2*pi (``checked_rotvec``), which
    degrees make."""
    v = _vector(pose_m_rad, 6, _named(source, "UR pose vector [x, y, z, rx, ry, rz]"))
    length_m = math.hypot(*v[:3].tolist())  # no overflow (and no numpy warning) at 1e308
    if not min_m <= length_m <= max_m:
        expected = f"{min_m:g} to {max_m:g} m" if min_m > 0.0 else f"at most {max_m:g} m"
        as_m = ""
        if length_m > max_m and min_m <= length_m / 1000.0 <= max_m:  # read as mm, it fits
            as_m = f": millimetres given? it must be in metres: {_shown(v[:3])} mm is "
            as_m += f"{_shown(v[:3] / 1000.0)} m"
        raise TransformError(
            _named(
                source,
                f"{distance} is {length_m:.6g} m long, expected {expected} (UR vectors are in "
                f"m){as_m}",
            )
        )
    return make_transform(rotation_from_rotvec(checked_rotvec(v[3:], source)), v[:3])


def checked_rotvec(rotvec_rad: ArrayLike, source: str | None = None) -> NDArray[np.float64]:
    """A rotation vector (axis times angle, rad) given from outside, as 3 floats; refused
    (``TransformError``) when it is longer than ``MAX_ROTVEC_RAD``: no turn needs more than a
    full one, and degrees typed for radians (127.3 for 2.2218) make every real one longer."""
    v = _vector(rotvec_rad, 3, _named(source, "rotation vector"))
    angle = math.hypot(*v.tolist())  # no overflow (and no numpy warning) at 1e308
    if angle > MAX_ROTVEC_RAD:
        as_rad = ""
        if math.radians(angle) <= MAX_ROTVEC_RAD:  # read as degrees, it is a rotation
            as_rad = f": {_shown(v)} deg is {_shown(np.radians(v))} rad"
        raise TransformError(
            _named(
                source,
                f"rotation vector is {angle:.6g} rad long, more than 2*pi (degrees given? "
                f"it must be in rad{as_rad})",
            )
        )
    return v


def _named(source: str | None, message: str) -> str:
    return message if source is None else f"{source}: {message}"


def _shown(values: NDArray[np.float64]) -> str:
    return "[" + ", ".join(f"{float(v):.5g}" for v in values) + "]"


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
#
# Quaternions are (x, y, z, w) here, unit length. Every conversion from a matrix goes through
# _quaternion_from_matrix, which also maps a matrix that is orthonormal only within
# ROTATION_TOLERANCE (float32 files) onto an exact rotation, as scipy's from_matrix does.

_SMALL_ANGLE = 1e-3
"""Below this angle (rad) sin(a/2)/a and a/sin(a/2) use their Taylor series (error < 1e-19)."""

GIMBAL_LOCK = 1e-7
"""Euler angles: the middle angle within this (rad) of its singular value counts as gimbal lock."""


def _quaternion_from_rotvec(rotvec: NDArray[np.float64]) -> NDArray[np.float64]:
    angle = float(np.linalg.norm(rotvec))
    if angle < _SMALL_ANGLE:
        sin_half_over_angle = 0.5 - angle**2 / 48.0 + angle**4 / 3840.0
    else:
        sin_half_over_angle = math.sin(angle / 2.0) / angle
    return np.array([*(rotvec * sin_half_over_angle), math.cos(angle / 2.0)])


def _matrix_from_unit_quaternion(q: NDArray[np.float64]) -> NDArray[np.float64]:
    x, y, z, w = (float(c) for c in q)
    return np.array(
        [
            [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w)],
            [2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w)],
            [2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y)],
        ]
    )


def _quaternion_from_matrix(R: ArrayLike, target: str) -> NDArray[np.float64]:
    """The unit quaternion (x, y, z, w) of a validated rotation, with w >= 0.

    Of the four squared components (each 4 q_k^2 is a sum of diagonal entries) the largest is
    taken by its square root and the other three from off-diagonal sums or differences divided
    by it: never a division by less than 1/2, so the result is exact at every angle, pi included.
    """
    # Refused rather than repaired: a scaled or sheared matrix is a wrong file, not a rotation.
    M = validate_rotation(R, f"rotation to convert to {target}")
    trace = M[0, 0] + M[1, 1] + M[2, 2]
    largest = int(np.argmax([M[0, 0], M[1, 1], M[2, 2], trace]))
    q = np.empty(4)
    if largest == 3:
        q[:] = [M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1], 1.0 + trace]
    else:
        i, j, k = largest, (largest + 1) % 3, (largest + 2) % 3
        q[i] = 1.0 - trace + 2.0 * M[i, i]
        q[j] = M[j, i] + M[i, j]
        q[k] = M[k, i] + M[i, k]
        q[3] = M[k, j] - M[j, k]
    q /= np.linalg.norm(q)
    return -q if q[3] < 0.0 else q


def rotation_from_rotvec(rotvec_rad: ArrayLike) -> NDArray[np.float64]:
    """Rotation vector (axis times angle, rad) -> 3x3 rotation matrix."""
    v = _vector(rotvec_rad, 3, "rotation vector")
    return _matrix_from_unit_quaternion(_quaternion_from_rotvec(v))


def rotation_to_rotvec(R: ArrayLike) -> NDArray[np.float64]:
    """3x3 rotation matrix -> rotation vector (rad), angle in [0, pi]; exact near pi and zero."""
    q = _quaternion_from_matrix(R, "rotation vector")
    sin_half = float(np.linalg.norm(q[:3]))
    angle = 2.0 * math.atan2(sin_half, float(q[3]))  # w >= 0, so the angle is in [0, pi]
    if angle < _SMALL_ANGLE:
        angle_over_sin_half = 2.0 + angle**2 / 12.0 + 7.0 * angle**4 / 2880.0
    else:
        angle_over_sin_half = angle / sin_half
    out: NDArray[np.float64] = q[:3] * angle_over_sin_half
    return out


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
    return _matrix_from_unit_quaternion(v / norm)


def rotation_to_quaternion(R: ArrayLike, order: QuaternionOrder) -> NDArray[np.float64]:
    """3x3 rotation matrix -> unit quaternion in the named order, with w >= 0.

    Of q and -q (the same rotation) the one with w > 0; at exactly 180 degrees (w = 0) the one
    whose first non-zero component is positive, as scipy's ``as_quat(canonical=True)``.
    """
    if order not in ("xyzw", "wxyz"):
        raise TransformError(f"unknown quaternion order {order!r}: expected 'xyzw' or 'wxyz'")
    q = _quaternion_from_matrix(R, f"quaternion ({order})")
    if q[3] == 0.0 and q[np.flatnonzero(q)[0]] < 0.0:
        q = -q
    return np.roll(q, 1) if order == "wxyz" else q


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


def _intrinsic_axes(sequence: str) -> list[int]:
    """Axis indices (x 0, y 1, z 2) of the sequence as intrinsic rotations, applied left to right.

    Extrinsic 'xyz' with angles (a, b, c) is R_z(c) R_y(b) R_x(a), which is intrinsic 'ZYX' with
    angles (c, b, a): extrinsic sequences are handled as their reversal.
    """
    axes = ["xyz".index(axis) for axis in check_euler_sequence(sequence).lower()]
    return axes if sequence.isupper() else axes[::-1]


def _axis_rotation(axis: int, angle: float) -> NDArray[np.float64]:
    """The 3x3 rotation by ``angle`` (rad) about base axis ``axis`` (x 0, y 1, z 2)."""
    j, k = (axis + 1) % 3, (axis + 2) % 3
    R = np.eye(3)
    R[j, j] = R[k, k] = math.cos(angle)
    R[k, j] = math.sin(angle)
    R[j, k] = -R[k, j]
    return R


def rotation_from_euler(angles: ArrayLike, sequence: str, unit: AngleUnit) -> NDArray[np.float64]:
    """Euler / roll-pitch-yaw angles with an explicit sequence and angle unit -> 3x3 rotation."""
    degrees = _check_angle_unit(unit)
    v = _vector(angles, 3, f"Euler angles ({sequence}, {unit})")
    axes = _intrinsic_axes(sequence)
    radians = np.radians(v) if degrees else v
    if sequence.islower():
        radians = radians[::-1]
    R = np.eye(3)
    for axis, angle in zip(axes, radians, strict=True):
        R = R @ _axis_rotation(axis, float(angle))
    return R


def rotation_to_euler(R: ArrayLike, sequence: str, unit: AngleUnit) -> NDArray[np.float64]:
    """3x3 rotation -> Euler angles in the named sequence and unit.

    Ranges as scipy gives them: outer angles in [-pi, pi], the middle one in [-pi/2, pi/2] for
    three different axes (Tait-Bryan, e.g. xyz) and in [0, pi] for a repeated axis (proper
    Euler, e.g. zxz). At gimbal lock (middle angle within ``GIMBAL_LOCK`` rad of its singular
    value) only the sum or difference of the outer angles is defined: the third angle of the
    sequence as written is set to 0, as scipy does, and the angles still give back the rotation
    within 1e-6 rad.
    """
    degrees = _check_angle_unit(unit)
    axes = _intrinsic_axes(sequence)
    q = _quaternion_from_matrix(R, f"Euler angles ({sequence}, {unit})")
    M = _matrix_from_unit_quaternion(q)
    # Extrinsic sequences were reversed, so the angle written third is the first intrinsic one.
    zero_first = sequence.islower()
    angles = np.array(_intrinsic_euler(M, axes, zero_first))
    if sequence.islower():
        angles = angles[::-1]
    return np.degrees(angles) if degrees else angles


def _intrinsic_euler(M: NDArray[np.float64], axes: list[int], zero_first: bool) -> list[float]:
    """Angles (a, b, c) with ``M = R_i(a) R_j(b) R_k(c)``, ``(i, j, k) = axes``.

    Read off one column and one row of M. With ``s`` the sign of the axis permutation
    (``e_i x e_j = s e_o``, ``o`` the axis other than i and j), for Tait-Bryan (k = o):
    column k is ``(s sin b, -s sin a cos b, cos a cos b)`` in rows (i, j, k) and row i is
    ``(cos b cos c, -s cos b sin c, s sin b)`` in columns (i, j, k). For proper Euler (k = i):
    column i is ``(cos b, sin a sin b, -s cos a sin b)`` in rows (i, j, o) and row i is
    ``(cos b, sin b sin c, s sin b cos c)`` in columns (i, j, o). At gimbal lock the angle
    named by ``zero_first`` (a, else c) is 0 and the other comes from row or column j.
    """
    i, j, k = axes
    o = 3 - i - j
    s = 1.0 if (j - i) % 3 == 1 else -1.0
    if k != i:  # Tait-Bryan
        cos_b = math.hypot(M[j, k], M[k, k])
        b = math.atan2(s * M[i, k], cos_b)
        locked = cos_b <= GIMBAL_LOCK
        if not locked:
            return [math.atan2(-s * M[j, k], M[k, k]), b, math.atan2(-s * M[i, j], M[i, i])]
        first_zero_c = math.atan2(s * M[j, i], M[j, j])
    else:  # proper Euler
        sin_b = math.hypot(M[j, i], M[o, i])
        b = math.atan2(sin_b, M[i, i])
        locked = sin_b <= GIMBAL_LOCK
        if not locked:
            return [math.atan2(M[j, i], -s * M[o, i]), b, math.atan2(M[i, j], s * M[i, o])]
        first_zero_c = math.atan2(-s * M[j, o], M[j, j])
    if zero_first:
        return [0.0, b, first_zero_c]
    return [math.atan2(s * M[o, j], M[j, j]), b, 0.0]
