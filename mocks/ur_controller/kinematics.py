"""Kinematics of UR arms (e-Series and CB3) for the simulated controller (nominal DH, analytic IK).

Self-contained on purpose (numpy + scipy only, never ``handeye_pick``): the simulator must not
share pose maths with the code it is testing, or a shared bug would cancel out.

Frames and units:

- ``base`` is the controller's base frame as the pendant shows it: frame 0 of UR's standard DH
  table, z up along joint 1. ``flange`` is the tool flange (DH frame 6, no TCP offset). ``tcp`` is
  the flange moved by the controller's TCP offset.
- ``T_a_b`` is the pose of ``b`` in ``a`` (``p_a = T_a_b @ p_b``), float64 4x4, metres.
- A UR pose vector is ``[x, y, z, rx, ry, rz]``: metres and a rotation vector in radians.
- Joint vectors ``q`` are 6 angles in radians, base joint first.

A real controller uses per-robot calibrated kinematics; these nominal ones differ by millimetres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

Matrix = NDArray[np.float64]
"""A float64 array: a 4x4 rigid transform or a joint/pose vector, as each signature says."""

IK_TOLERANCE = 1e-9
"""Largest accepted |forward(q) - T| entry (metres for position, unitless for rotation)."""

LIMIT_TOLERANCE_RAD = 1e-6
"""A joint solved this close beyond a limit is round-off (a stretched arm solves q3 to ~1e-7)."""

SINGULAR_WRIST_TOLERANCE = 1e-12
"""|sin q5| below this is a singular wrist: q6 is then free and chosen (see ``_singular_q6``)."""

NEAR_SINGULAR_WRIST_TOLERANCE = 1e-5
"""|sin q5| below this: q6 is only known to ~1e-16 / |sin q5| rad from the flange rotation.

That error turns q6 about an axis nearly parallel to joint 4's, so the pose barely notices, but
it moves the origin of frame 4 by d5 times it: enough to put a stretched or folded arm
(sin q3 ~ 0) just out of reach and lose a valid solution. Below this the computed q6 is kept only
when the arm reaches with it, else the nearest q6 that reaches is used (``_singular_q6``); the
forward check in ``inverse_all`` still judges the result.
"""

_ROTATION_TOLERANCE = 1e-6
_FULL_TURN = 2.0 * math.pi
_JOINT_LIMIT_RAD = 2.0 * math.pi
_UR_ALPHA = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)


@dataclass(frozen=True)
class URModel:
    """Nominal standard-DH kinematics of one UR arm (metres, radians).

    ``d``, ``a`` and ``alpha`` are the six DH rows as published by Universal Robots;
    the analytic IK relies on their UR shape (a1 = a4 = a5 = a6 = 0, d2 = d3 = 0, alpha as in
    ``_UR_ALPHA``).
    """

    name: str
    d: tuple[float, float, float, float, float, float]
    a: tuple[float, float, float, float, float, float]
    alpha: tuple[float, float, float, float, float, float]
    reach_m: float
    joint_min_rad: tuple[float, float, float, float, float, float]
    joint_max_rad: tuple[float, float, float, float, float, float]


def _ur_model(
    name: str, d1: float, a2: float, a3: float, d4: float, d5: float, d6: float, reach_m: float
) -> URModel:
    lo = -_JOINT_LIMIT_RAD
    hi = _JOINT_LIMIT_RAD
    return URModel(
        name=name,
        d=(d1, 0.0, 0.0, d4, d5, d6),
        a=(0.0, a2, a3, 0.0, 0.0, 0.0),
        alpha=_UR_ALPHA,
        reach_m=reach_m,
        joint_min_rad=(lo, lo, lo, lo, lo, lo),
        joint_max_rad=(hi, hi, hi, hi, hi, hi),
    )


MODELS: dict[str, URModel] = {
    "ur3e": _ur_model("ur3e", 0.15185, -0.24355, -0.2132, 0.13105, 0.08535, 0.0921, 0.50),
    "ur5e": _ur_model("ur5e", 0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996, 0.85),
    "ur10e": _ur_model("ur10e", 0.1807, -0.6127, -0.57155, 0.17415, 0.11985, 0.11655, 1.30),
    "ur16e": _ur_model("ur16e", 0.1807, -0.4784, -0.36, 0.17415, 0.11985, 0.11655, 0.90),
}
"""Nominal e-Series models by lower-case name."""

CB3_MODELS: dict[str, URModel] = {
    "ur3": _ur_model("ur3", 0.1519, -0.24365, -0.21325, 0.11235, 0.08535, 0.0819, 0.50),
    "ur5": _ur_model("ur5", 0.089159, -0.425, -0.39225, 0.10915, 0.09465, 0.0823, 0.85),
    "ur10": _ur_model("ur10", 0.1273, -0.612, -0.5723, 0.163941, 0.1157, 0.0922, 1.30),
}
"""Nominal CB3 models (the cb3 profile's arms), from the same UR publication."""

ALL_MODELS: dict[str, URModel] = {**MODELS, **CB3_MODELS}


# --- input checks -------------------------------------------------------------------------------


def _vector(values: ArrayLike, length: int, operation: str, what: str) -> Matrix:
    arr = np.asarray(values, dtype=np.float64)
    if arr.shape != (length,):
        raise ValueError(f"{operation}: {what} must have shape ({length},), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{operation}: {what} has non-finite entries: {arr.tolist()}")
    return arr


def _transform(T: ArrayLike, operation: str, what: str) -> Matrix:
    arr = np.asarray(T, dtype=np.float64)
    if arr.shape != (4, 4):
        raise ValueError(f"{operation}: {what} must be 4x4, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{operation}: {what} has non-finite entries")
    if not np.array_equal(arr[3], [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"{operation}: {what} bottom row must be [0, 0, 0, 1], got {arr[3]}")
    R = arr[:3, :3]
    ortho_err = float(np.max(np.abs(R.T @ R - np.eye(3))))
    if ortho_err > _ROTATION_TOLERANCE or np.linalg.det(R) < 0.0:
        raise ValueError(
            f"{operation}: {what} rotation is not a proper rotation "
            f"(max |R^T R - I| = {ortho_err:.1e}, det = {np.linalg.det(R):.6f})"
        )
    return arr


# --- pose vectors and transforms ----------------------------------------------------------------


def rotvec_to_matrix(rotvec: Matrix) -> Matrix:
    """Rotation vector (axis times angle, rad) -> 3x3 rotation matrix (Rodrigues' formula).

    Written out in numpy rather than through scipy's Rotation: the control loop converts poses
    several times per 2 ms cycle, and scipy's per-call overhead alone took most of a cycle."""
    x, y, z = (float(v) for v in rotvec)
    angle = math.sqrt(x * x + y * y + z * z)
    if angle < 1e-8:  # second-order series: exact to double precision this close to zero
        sin_term, cos_term = 1.0 - angle * angle / 6.0, 0.5 - angle * angle / 24.0
    else:
        sin_term, cos_term = math.sin(angle) / angle, (1.0 - math.cos(angle)) / (angle * angle)
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    R: Matrix = np.eye(3) + sin_term * K + cos_term * (K @ K)
    return R


def matrix_to_rotvec(R: Matrix) -> Matrix:
    """3x3 rotation matrix -> rotation vector (rad), angle in [0, pi], through the unit
    quaternion taken from the matrix's largest diagonal term (stable for every angle, pi
    included), its scalar part made >= 0."""
    trace = R[0, 0] + R[1, 1] + R[2, 2]
    largest = int(np.argmax([R[0, 0], R[1, 1], R[2, 2], trace]))
    quat = np.empty(4)  # x, y, z, w
    if largest == 3:
        quat[:3] = R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]
        quat[3] = 1.0 + trace
    else:
        i, j, k = largest, (largest + 1) % 3, (largest + 2) % 3
        quat[i] = 1.0 - trace + 2.0 * R[i, i]
        quat[j] = R[j, i] + R[i, j]
        quat[k] = R[k, i] + R[i, k]
        quat[3] = R[k, j] - R[j, k]
    quat /= np.linalg.norm(quat)
    if quat[3] < 0.0:
        quat = -quat
    sin_half = float(np.linalg.norm(quat[:3]))
    angle = 2.0 * math.atan2(sin_half, float(quat[3]))
    scale = 2.0 + angle * angle / 12.0 if angle < 1e-3 else angle / math.sin(angle / 2.0)
    result: Matrix = scale * quat[:3]
    return result


def pose_to_matrix(pose: ArrayLike) -> Matrix:
    """UR pose ``[x, y, z, rx, ry, rz]`` (m, rotation vector rad) -> 4x4 transform."""
    p = _vector(pose, 6, "pose_to_matrix", "pose")
    T = np.eye(4)
    T[:3, :3] = rotvec_to_matrix(p[3:])
    T[:3, 3] = p[:3]
    return T


def matrix_to_pose(T: ArrayLike) -> Matrix:
    """4x4 transform -> UR pose ``[x, y, z, rx, ry, rz]`` (m, rad; rotation angle in [0, pi])."""
    arr = _transform(T, "matrix_to_pose", "T")
    return np.concatenate([arr[:3, 3], matrix_to_rotvec(arr[:3, :3])])


def _invert(T: Matrix) -> Matrix:
    """Closed-form inverse of a rigid transform, or of each in a stack (..., 4, 4)."""
    R_t = np.swapaxes(T[..., :3, :3], -1, -2)
    inv = np.zeros_like(T)
    inv[..., :3, :3] = R_t
    inv[..., :3, 3] = -(R_t @ T[..., :3, 3:])[..., 0]
    inv[..., 3, 3] = 1.0
    return inv


def tcp_from_flange(T_base_flange: ArrayLike, tcp_offset_pose: ArrayLike) -> Matrix:
    """``T_base_tcp`` from the flange pose and the TCP offset (``T_flange_tcp`` as a UR pose)."""
    T_bf = _transform(T_base_flange, "tcp_from_flange", "T_base_flange")
    return T_bf @ pose_to_matrix(tcp_offset_pose)


def flange_from_tcp(T_base_tcp: ArrayLike, tcp_offset_pose: ArrayLike) -> Matrix:
    """``T_base_flange`` from the TCP pose and the TCP offset (``T_flange_tcp`` as a UR pose)."""
    T_bt = _transform(T_base_tcp, "flange_from_tcp", "T_base_tcp")
    return T_bt @ _invert(pose_to_matrix(tcp_offset_pose))


# --- forward and inverse kinematics -------------------------------------------------------------


def forward(model: URModel, q: ArrayLike) -> Matrix:
    """``T_base_flange`` (4x4, m) for joint angles ``q`` (6, rad)."""
    joints = _vector(q, 6, "forward", "q")
    T_base_flange: Matrix = _forward_many(model, joints[np.newaxis])[0]
    return T_base_flange


def elbow_position(model: URModel, q: ArrayLike) -> Matrix:
    """Position (3, m) of the elbow in base: DH frame 2's origin, on joint 3's axis."""
    links = _links(model, _vector(q, 6, "elbow_position", "q")[np.newaxis])[0]
    position: Matrix = (links[0] @ links[1])[:3, 3]
    return position


def _links(model: URModel, Q: Matrix) -> Matrix:
    """DH link transforms for each row of ``Q`` (n, 6): shape (n, 6, 4, 4), link i-1 -> i.

    Standard DH: Rz(theta) Tz(d) Tx(a) Rx(alpha).
    """
    ct, st = np.cos(Q), np.sin(Q)
    ca, sa = np.cos(model.alpha), np.sin(model.alpha)
    a, d = np.asarray(model.a), np.asarray(model.d)
    zero, one = np.zeros_like(Q), np.ones_like(Q)
    rows = [
        [ct, -st * ca, st * sa, a * ct],
        [st, ct * ca, -ct * sa, a * st],
        [zero, sa + zero, ca + zero, d + zero],
        [zero, zero, zero, one],
    ]
    links: Matrix = np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)
    return links


def frames(model: URModel, Q: ArrayLike) -> Matrix:
    """``T_base_frame`` of DH frames 0 to 6 (frame 6: the flange) for each row of ``Q``
    (n, 6): shape (n, 7, 4, 4)."""
    Q = np.atleast_2d(np.asarray(Q, dtype=np.float64))
    links = _links(model, Q)
    out = np.empty((Q.shape[0], 7, 4, 4))
    out[:, 0] = np.eye(4)
    for i in range(6):
        out[:, i + 1] = out[:, i] @ links[:, i]
    return out


def _forward_many(model: URModel, Q: Matrix) -> Matrix:
    """``T_base_flange`` for each row of ``Q`` (n, 6): shape (n, 4, 4). One numpy pass for all."""
    links = _links(model, Q)
    T = links[:, 0]
    for i in range(1, 6):
        T = T @ links[:, i]
    return T


def _wrap_pi(angles: Matrix) -> Matrix:
    """Angles in (-pi, pi]."""
    return math.pi - np.remainder(math.pi - angles, _FULL_TURN)


def _branch_sqrt(value: float, tolerance: float) -> float | None:
    """sqrt(value), treating -tolerance < value < 0 as round-off; None when truly negative."""
    if value < -tolerance:
        return None
    return math.sqrt(max(value, 0.0))


def inverse_all(
    model: URModel, T_base_flange: ArrayLike, q6_if_singular: float = 0.0
) -> list[Matrix]:
    """All joint solutions (up to 8, each in (-pi, pi] per joint) reaching ``T_base_flange``.

    Closed form for the UR geometry (three parallel middle axes, offset wrist). Each solution is
    checked with ``forward`` to ``IK_TOLERANCE``; an unreachable pose gives an empty list. At a
    wrist singularity (sin q5 = 0) q6 is free: it is ``q6_if_singular`` when the arm can reach
    with that, else the nearest q6 that can (see ``_singular_q6``).
    Joint limits are not applied here (see ``inverse``).
    """
    T = _transform(T_base_flange, "inverse_all", "T_base_flange")
    d4, d6 = model.d[3], model.d[5]
    a2, a3 = model.a[1], model.a[2]
    R = T[:3, :3]

    # Joint 1: the wrist centre p05 lies at distance d4 from the base plane containing z1.
    p05 = T[:3, 3] - d6 * R[:, 2]
    r_sq = float(p05[0] ** 2 + p05[1] ** 2)
    along = _branch_sqrt(r_sq - d4 * d4, 1e-12)
    if along is None:
        return []
    phi = math.atan2(float(p05[1]), float(p05[0]))
    q1_options = [phi + math.atan2(d4, along), phi + math.atan2(d4, -along)]

    # Joints 1, 5, 6 for each shoulder and wrist branch.
    wrist_rows: list[list[float]] = []
    for q1 in q1_options:
        # Joint 1's axis z1 expressed in the flange frame is [s5 c6, -s5 s6, c5].
        z1_in_flange = R.T @ np.array([math.sin(q1), -math.cos(q1), 0.0])
        c5 = float(z1_in_flange[2])
        s5_abs = math.hypot(float(z1_in_flange[0]), float(z1_in_flange[1]))
        for wrist_sign in (1.0, -1.0):
            q5 = math.atan2(wrist_sign * s5_abs, c5)
            if s5_abs < SINGULAR_WRIST_TOLERANCE:
                q6 = _singular_q6(model, T, q1, q5, q6_if_singular)
            else:
                q6 = math.atan2(
                    -wrist_sign * float(z1_in_flange[1]), wrist_sign * float(z1_in_flange[0])
                )
                if s5_abs < NEAR_SINGULAR_WRIST_TOLERANCE:
                    q6 = _singular_q6(model, T, q1, q5, q6)
            wrist_rows.append([q1, q5, q6])

    candidates: list[list[float]] = []
    T_14_rows = _T_1_4(model, T, np.array(wrist_rows))
    for (q1, q5, q6), T_14 in zip(wrist_rows, T_14_rows, strict=True):
        # Joints 2-4 form a planar arm in the x-y plane of frame 1.
        x, y = float(T_14[0, 3]), float(T_14[1, 3])
        c3 = (x * x + y * y - a2 * a2 - a3 * a3) / (2.0 * a2 * a3)
        s3_abs = _branch_sqrt(1.0 - c3 * c3, 1e-9)
        if s3_abs is None:
            continue
        c3 = max(-1.0, min(1.0, c3))
        q234 = math.atan2(float(T_14[1, 0]), float(T_14[0, 0]))
        for elbow_sign in (1.0, -1.0):
            s3 = elbow_sign * s3_abs
            q3 = math.atan2(s3, c3)
            q2 = math.atan2(y, x) - math.atan2(a3 * s3, a2 + a3 * c3)
            q4 = q234 - q2 - q3
            candidates.append([q1, q2, q3, q4, q5, q6])
    if not candidates:
        return []
    Q = _wrap_pi(np.array(candidates))
    errors = np.max(np.abs(_forward_many(model, Q)[:, :3] - T[:3]), axis=(1, 2))
    Q = Q[errors <= IK_TOLERANCE]
    # Branches meet at singularities (a stretched arm, a singular wrist): keep one of each.
    gaps = np.max(np.abs(_wrap_pi(Q[:, np.newaxis] - Q[np.newaxis])), axis=2)
    repeats = np.any(np.tril(gaps <= IK_TOLERANCE, k=-1), axis=1)
    return list(Q[~repeats])


def _T_1_4(model: URModel, T_base_flange: Matrix, q1_q5_q6: Matrix) -> Matrix:
    """Frame 4 in frame 1 for each row [q1, q5, q6] (n, 3): what the planar arm must reach."""
    q = np.zeros((len(q1_q5_q6), 6))
    q[:, [0, 4, 5]] = q1_q5_q6
    links = _links(model, q)
    T_1_0 = _invert(links[:, 0])
    T_4_6 = links[:, 4] @ links[:, 5]
    T_1_4: Matrix = T_1_0 @ T_base_flange @ _invert(T_4_6)
    return T_1_4


def _singular_q6(
    model: URModel, T_base_flange: Matrix, q1: float, q5: float, q6_preferred: float
) -> float:
    """q6 for a singular wrist (sin q5 = 0): ``q6_preferred`` if the planar arm then reaches.

    With sin q5 = 0 the axes of joints 2, 3, 4 and 6 are parallel, so q6 is free; it moves the
    origin of frame 4 on a circle of radius d5 in the x-y plane of frame 1. The planar arm reaches
    an annulus around joint 2; when ``q6_preferred`` puts the origin outside it, the nearest q6
    on the annulus edge is used instead (a stretched or folded arm).
    """

    rows = np.array([[q1, q5, 0.0], [q1, q5, math.pi / 2], [q1, q5, math.pi]])
    origin_0, origin_90, origin_180 = _T_1_4(model, T_base_flange, rows)[:, :2, 3]
    centre = 0.5 * (origin_0 + origin_180)
    at_0 = origin_0 - centre
    at_90 = origin_90 - centre
    # Angle of the origin on the circle: psi = turn * q6 + offset, seen from joint 2's direction.
    turn = 1.0 if at_0[0] * at_90[1] - at_0[1] * at_90[0] > 0.0 else -1.0
    offset = math.atan2(float(at_0[1]), float(at_0[0])) - math.atan2(
        float(centre[1]), float(centre[0])
    )
    centre_m = math.hypot(float(centre[0]), float(centre[1]))
    d5 = model.d[4]
    if centre_m * d5 < 1e-12:
        return q6_preferred  # circle centred on joint 2: every q6 is equally reachable

    def cos_psi_at(radius: float) -> float:
        return (radius * radius - centre_m * centre_m - d5 * d5) / (2.0 * d5 * centre_m)

    a2, a3 = abs(model.a[1]), abs(model.a[2])
    cos_low, cos_high = cos_psi_at(abs(a2 - a3)), cos_psi_at(a2 + a3)
    psi_preferred = turn * q6_preferred + offset
    if cos_low <= math.cos(psi_preferred) <= cos_high:
        return q6_preferred
    edges = [
        sign * math.acos(max(-1.0, min(1.0, cos_edge)))
        for cos_edge in (cos_low, cos_high)
        for sign in (1.0, -1.0)
    ]
    psi = min(edges, key=lambda edge: abs(math.remainder(edge - psi_preferred, _FULL_TURN)))
    return turn * (psi - offset)


def _nearest_turn(model: URModel, Q: Matrix, q_near: Matrix) -> tuple[Matrix, NDArray[np.bool_]]:
    """Rows of ``Q`` (n, 6) with each joint shifted by whole turns to be nearest ``q_near``.

    Returns the shifted rows and which of them fit the joint limits. A joint that overshoots a
    limit by round-off only (``LIMIT_TOLERANCE_RAD``) is put on the limit, so a target taken at
    exactly +-2 pi keeps its turn.
    """
    lo = np.asarray(model.joint_min_rad)
    hi = np.asarray(model.joint_max_rad)
    # Turn counts around q_near clipped into the limits, so a far-off q_near still finds them.
    centre = np.clip(q_near, lo, hi)
    turns = np.round((centre - Q) / _FULL_TURN) + np.array([-1.0, 0.0, 1.0])[:, None, None]
    shifted = Q + turns * _FULL_TURN  # (3, n, 6): one layer per turn count
    allowed = (shifted >= lo - LIMIT_TOLERANCE_RAD) & (shifted <= hi + LIMIT_TOLERANCE_RAD)
    gaps = np.where(allowed, np.abs(shifted - q_near), math.inf)
    best_turn = np.argmin(gaps, axis=0)  # (n, 6)
    nearest = np.clip(np.take_along_axis(shifted, best_turn[np.newaxis], axis=0)[0], lo, hi)
    fits: NDArray[np.bool_] = np.all(np.any(allowed, axis=0), axis=1)
    return nearest, fits


def inverse(model: URModel, T_base_flange: ArrayLike, q_near: ArrayLike) -> Matrix | None:
    """The joint solution reaching ``T_base_flange`` nearest ``q_near`` (Euclidean, rad).

    Each joint is moved by whole turns to be nearest ``q_near`` while staying within the model's
    limits; a joint snapped onto a limit (``LIMIT_TOLERANCE_RAD``) may cost ~1e-6 m of accuracy.
    At a wrist singularity q6 keeps ``q_near[5]`` when the arm can reach with it. None when the
    pose is unreachable.
    """
    near = _vector(q_near, 6, "inverse", "q_near")
    solutions = inverse_all(model, T_base_flange, q6_if_singular=float(near[5]))
    if not solutions:
        return None
    shifted, fits = _nearest_turn(model, np.array(solutions), near)
    if not np.any(fits):
        return None
    distances = np.where(fits, np.linalg.norm(shifted - near, axis=1), math.inf)
    best: Matrix = shifted[int(np.argmin(distances))]
    return best


def within_limits(model: URModel, q: ArrayLike) -> bool:
    """True when every joint of ``q`` (rad) is within the model's limits (inclusive)."""
    joints = _vector(q, 6, "within_limits", "q")
    return bool(
        np.all(joints >= np.asarray(model.joint_min_rad))
        and np.all(joints <= np.asarray(model.joint_max_rad))
    )


def reachable(model: URModel, T_base_flange: ArrayLike) -> bool:
    """True when some joint solution within limits reaches ``T_base_flange``."""
    return inverse(model, T_base_flange, np.zeros(6)) is not None


# --- motion profile helpers ---------------------------------------------------------------------


def interpolate_pose(T0: ArrayLike, T1: ArrayLike, s: float) -> Matrix:
    """Pose a fraction ``s`` in [0, 1] of the way from ``T0`` to ``T1`` (same parent frame).

    Position moves on the straight line, orientation by slerp (shortest rotation).
    """
    A = _transform(T0, "interpolate_pose", "T0")
    B = _transform(T1, "interpolate_pose", "T1")
    if not 0.0 <= s <= 1.0:
        raise ValueError(f"interpolate_pose: fraction s must be in [0, 1], got {s}")
    R0 = A[:3, :3]
    relative = matrix_to_rotvec(R0.T @ B[:3, :3])
    T = np.eye(4)
    T[:3, :3] = R0 @ rotvec_to_matrix(s * relative)
    T[:3, 3] = (1.0 - s) * A[:3, 3] + s * B[:3, 3]
    return T


def _check_profile(distance: float, v_max: float, a_max: float, operation: str) -> None:
    if not (math.isfinite(distance) and distance >= 0.0):
        raise ValueError(f"{operation}: distance must be finite and >= 0, got {distance}")
    if not (math.isfinite(v_max) and v_max > 0.0):
        raise ValueError(f"{operation}: v_max must be finite and > 0, got {v_max}")
    if not (math.isfinite(a_max) and a_max > 0.0):
        raise ValueError(f"{operation}: a_max must be finite and > 0, got {a_max}")


def _peak_speed(distance: float, v_max: float, a_max: float) -> float:
    """v_max, or the lower peak of a triangular profile when the move is too short to reach it."""
    return min(v_max, math.sqrt(distance * a_max))


def trapezoid(distance: float, v_max: float, a_max: float) -> float:
    """Duration (s) of a rest-to-rest move over ``distance`` with speed and acceleration caps.

    Units are any consistent set (m, m/s, m/s^2 or rad, rad/s, rad/s^2). Triangular profile
    (duration 2 sqrt(distance / a_max)) when ``distance < v_max**2 / a_max``.
    """
    _check_profile(distance, v_max, a_max, "trapezoid")
    v_peak = _peak_speed(distance, v_max, a_max)
    if v_peak == 0.0:
        return 0.0
    return distance / v_peak + v_peak / a_max


def trapezoid_fraction(t: float, distance: float, v_max: float, a_max: float) -> float:
    """Fraction in [0, 1] of ``distance`` covered at time ``t`` (s) of the ``trapezoid`` move."""
    _check_profile(distance, v_max, a_max, "trapezoid_fraction")
    duration = trapezoid(distance, v_max, a_max)
    if t >= duration:
        return 1.0
    if t <= 0.0:
        return 0.0
    v_peak = _peak_speed(distance, v_max, a_max)
    t_ramp = v_peak / a_max
    if t < t_ramp:
        covered = 0.5 * a_max * t * t
    elif t <= duration - t_ramp:
        covered = 0.5 * v_peak * t_ramp + v_peak * (t - t_ramp)
    else:
        remaining = duration - t
        covered = distance - 0.5 * a_max * remaining * remaining
    return min(1.0, max(0.0, covered / distance))
