"""Pose maths: property tests for every conversion, with angles at 0, 1e-9, pi - 1e-7 and pi.

Rotations are compared as rotations (rotation_angle_between), never rotation vectors component by
component: near pi, [0, 3.1415, 0] and [0, -3.1415, 0] are the same rotation within 0.01 deg.
"""

from __future__ import annotations

import itertools
import math
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from handeye_pick.errors import TransformError
from handeye_pick.geometry import (
    check_euler_sequence,
    compose,
    invert,
    make_transform,
    matrix_to_ur_pose,
    metres_per,
    rotation_angle_between,
    rotation_from_euler,
    rotation_from_quaternion,
    rotation_from_rotvec,
    rotation_to_euler,
    rotation_to_quaternion,
    rotation_to_rotvec,
    scale_translation,
    transform_point,
    ur_pose_to_matrix,
    validate_rotation,
    validate_transform,
)

SPECIAL_ANGLES = [0.0, 1e-9, math.pi - 1e-7, math.pi]
ROT_TOL = 1e-9  # rad; float64 conversions lose far less than this
LEN_TOL = 1e-12  # m

finite = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
angles = st.one_of(st.sampled_from(SPECIAL_ANGLES), st.floats(0.0, math.pi))
axes = (
    st.tuples(finite, finite, finite)
    .map(np.array)
    .filter(lambda v: np.linalg.norm(v) > 0.1)
    .map(lambda v: v / np.linalg.norm(v))
)
# Axis-aligned axes too: the near-pi branch of a log map is where naive code fails.
unit_axes = st.one_of(axes, st.sampled_from([np.eye(3)[i] * s for i in range(3) for s in (1, -1)]))
rotvecs = st.builds(lambda axis, angle: axis * angle, unit_axes, angles)
translations = st.tuples(
    *(st.floats(-2.0, 2.0, allow_nan=False, allow_infinity=False) for _ in range(3))
).map(np.array)
ur_poses = st.builds(lambda t, r: np.concatenate([t, r]), translations, rotvecs)
transforms = ur_poses.map(ur_pose_to_matrix)
rotations = rotvecs.map(rotation_from_rotvec)
sequences = st.sampled_from(["xyz", "zyx", "XYZ", "ZYX", "zxz", "ZXZ", "yzx"])


def rotation_about(axis: int, angle: float) -> NDArray[np.float64]:
    rotvec = np.zeros(3)
    rotvec[axis] = angle
    return rotation_from_rotvec(rotvec)


# --- UR pose vectors and rotation vectors ---------------------------------------------------------


@given(ur_poses)
def test_ur_pose_round_trip_is_the_same_pose(pose: NDArray[np.float64]) -> None:
    T = ur_pose_to_matrix(pose)
    validate_transform(T, "ur_pose_to_matrix")
    back = matrix_to_ur_pose(T)
    assert rotation_angle_between(T[:3, :3], ur_pose_to_matrix(back)[:3, :3]) < ROT_TOL
    np.testing.assert_allclose(back[:3], pose[:3], atol=LEN_TOL)
    assert np.linalg.norm(back[3:]) <= math.pi + 1e-12


@given(rotvecs)
def test_rotvec_round_trip_keeps_the_angle(rotvec: NDArray[np.float64]) -> None:
    R = rotation_from_rotvec(rotvec)
    back = rotation_to_rotvec(R)
    assert rotation_angle_between(R, rotation_from_rotvec(back)) < ROT_TOL
    assert abs(np.linalg.norm(back) - np.linalg.norm(rotvec)) < 1e-8


@pytest.mark.parametrize("angle", SPECIAL_ANGLES)
@pytest.mark.parametrize("axis", range(3))
def test_rotation_angle_of_special_angles_is_exact(axis: int, angle: float) -> None:
    assert abs(rotation_angle_between(np.eye(3), rotation_about(axis, angle)) - angle) < 1e-12


def test_rotvecs_of_opposite_sign_near_pi_are_nearly_the_same_rotation() -> None:
    # Component by component these differ by 6.28; as rotations they are 1.9e-4 rad apart.
    R1 = rotation_from_rotvec([0.0, 3.1415, 0.0])
    R2 = rotation_from_rotvec([0.0, -3.1415, 0.0])
    assert rotation_angle_between(R1, R2) == pytest.approx(2 * (math.pi - 3.1415), abs=1e-12)


def test_ur_pose_known_value_quarter_turn_about_z() -> None:
    T = ur_pose_to_matrix([0.1, 0.2, 0.3, 0.0, 0.0, math.pi / 2])
    # x of the new frame is y of the old one; the translation is metres, untouched.
    np.testing.assert_allclose(transform_point(T, [1.0, 0.0, 0.0]), [0.1, 1.2, 0.3], atol=1e-15)


def test_ur_pose_vector_refuses_wrong_length_and_nan() -> None:
    with pytest.raises(TransformError, match="6 numbers"):
        ur_pose_to_matrix([0.0, 0.0, 0.0, 0.0, 0.0])
    with pytest.raises(TransformError, match="non-finite"):
        ur_pose_to_matrix([0.0, 0.0, math.nan, 0.0, 0.0, 0.0])


# --- quaternions ----------------------------------------------------------------------------------


@given(rotations)
def test_quaternion_round_trip_both_orders(R: NDArray[np.float64]) -> None:
    q_xyzw = rotation_to_quaternion(R, "xyzw")
    q_wxyz = rotation_to_quaternion(R, "wxyz")
    np.testing.assert_array_equal(q_wxyz, np.roll(q_xyzw, 1))
    assert q_xyzw[3] >= 0.0
    assert rotation_angle_between(R, rotation_from_quaternion(q_xyzw, "xyzw")) < ROT_TOL
    assert rotation_angle_between(R, rotation_from_quaternion(q_wxyz, "wxyz")) < ROT_TOL
    # q and -q are the same rotation.
    assert rotation_angle_between(R, rotation_from_quaternion(-q_xyzw, "xyzw")) < ROT_TOL


def test_quaternion_order_matters() -> None:
    q = [0.0, 0.0, math.sin(0.5), math.cos(0.5)]  # 1 rad about z, xyzw
    R_right = rotation_from_quaternion(q, "xyzw")
    R_wrong = rotation_from_quaternion(q, "wxyz")
    assert rotation_angle_between(R_right, rotation_about(2, 1.0)) < ROT_TOL
    assert rotation_angle_between(R_right, R_wrong) > 0.5


def test_quaternion_refuses_non_unit_and_unknown_order() -> None:
    with pytest.raises(TransformError, match="unit norm"):
        rotation_from_quaternion([0.0, 0.0, 0.0, 2.0], "xyzw")
    with pytest.raises(TransformError, match="unknown quaternion order"):
        rotation_from_quaternion([0.0, 0.0, 0.0, 1.0], "wzyx")  # type: ignore[arg-type]


# --- Euler / roll-pitch-yaw -----------------------------------------------------------------------


@given(rotations, sequences, st.sampled_from(["deg", "rad"]))
def test_euler_round_trip(R: NDArray[np.float64], sequence: str, unit: str) -> None:
    angles_out = rotation_to_euler(R, sequence, unit)  # type: ignore[arg-type]
    R_back = rotation_from_euler(angles_out, sequence, unit)  # type: ignore[arg-type]
    # Gimbal lock keeps the rotation, not the individual angles; compare rotations only. Within
    # 1e-7 rad of the lock scipy drops the third angle, which costs up to 2e-7 rad.
    assert rotation_angle_between(R, R_back) < 1e-6


@given(st.tuples(finite, finite, finite))
def test_extrinsic_xyz_is_intrinsic_zyx_reversed(abc: tuple[float, float, float]) -> None:
    a, b, c = abc
    R_ext = rotation_from_euler([a, b, c], "xyz", "rad")
    R_int = rotation_from_euler([c, b, a], "ZYX", "rad")
    assert rotation_angle_between(R_ext, R_int) < ROT_TOL


def test_extrinsic_and_intrinsic_differ_and_units_matter() -> None:
    abc = [0.3, -0.4, 1.1]
    R_ext = rotation_from_euler(abc, "xyz", "rad")
    assert rotation_angle_between(R_ext, rotation_from_euler(abc, "XYZ", "rad")) > 0.1
    assert rotation_angle_between(R_ext, rotation_from_euler(abc, "xyz", "deg")) > 0.1
    R_deg = rotation_from_euler(np.degrees(abc), "xyz", "deg")
    assert rotation_angle_between(R_ext, R_deg) < ROT_TOL


def test_roll_pitch_yaw_known_value() -> None:
    # Yaw 90 deg about the fixed z axis maps x onto y.
    R = rotation_from_euler([0.0, 0.0, 90.0], "xyz", "deg")
    np.testing.assert_allclose(R @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-15)


@pytest.mark.parametrize("sequence", ["xy", "xyzx", "xYz", "xxy", "abc", ""])
def test_bad_euler_sequence_is_refused(sequence: str) -> None:
    with pytest.raises(TransformError, match="Euler sequence"):
        check_euler_sequence(sequence)


def test_bad_angle_unit_is_refused() -> None:
    with pytest.raises(TransformError, match="angle unit"):
        rotation_from_euler([0.0, 0.0, 0.0], "xyz", "grad")  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "convert",
    [
        rotation_to_rotvec,
        lambda R: rotation_to_quaternion(R, "xyzw"),
        lambda R: rotation_to_euler(R, "xyz", "rad"),
    ],
)
def test_conversions_refuse_a_non_rotation_instead_of_repairing_it(convert: object) -> None:
    with pytest.raises(TransformError, match="not orthonormal"):
        convert(np.diag([1.0, 1.0, 1.1]))  # type: ignore[operator]


# --- inverse, compose, points ---------------------------------------------------------------------


@given(transforms)
def test_inverse_laws(T: NDArray[np.float64]) -> None:
    Ti = invert(T)
    validate_transform(Ti, "invert")
    np.testing.assert_allclose(compose(T, Ti), np.eye(4), atol=1e-12)
    np.testing.assert_allclose(compose(Ti, T), np.eye(4), atol=1e-12)
    np.testing.assert_allclose(invert(Ti), T, atol=1e-12)
    np.testing.assert_allclose(Ti, np.linalg.inv(T), atol=1e-12)


@given(transforms, transforms, transforms)
def test_compose_laws(
    A: NDArray[np.float64], B: NDArray[np.float64], C: NDArray[np.float64]
) -> None:
    np.testing.assert_allclose(compose(compose(A, B), C), compose(A, compose(B, C)), atol=1e-12)
    np.testing.assert_allclose(invert(compose(A, B)), compose(invert(B), invert(A)), atol=1e-12)
    np.testing.assert_array_equal(compose(A), A)
    np.testing.assert_array_equal(compose(), np.eye(4))


@given(transforms, transforms, translations)
def test_transform_point_follows_the_chain(
    T_a_b: NDArray[np.float64], T_b_c: NDArray[np.float64], p_c: NDArray[np.float64]
) -> None:
    p_a = transform_point(compose(T_a_b, T_b_c), p_c)
    np.testing.assert_allclose(p_a, transform_point(T_a_b, transform_point(T_b_c, p_c)), atol=1e-12)


def test_chain_order_matters() -> None:
    # A wrong frame order gives a different point: the chain is not commutative.
    T_base_flange = ur_pose_to_matrix([0.5, 0.1, 0.4, 0.0, math.pi, 0.0])
    T_flange_cam = ur_pose_to_matrix([0.05, 0.0, 0.08, 0.0, 0.0, math.pi / 2])
    p_cam = np.array([0.01, 0.02, 0.3])
    right = transform_point(compose(T_base_flange, T_flange_cam), p_cam)
    swapped = transform_point(compose(T_flange_cam, T_base_flange), p_cam)
    assert np.linalg.norm(right - swapped) > 0.1


def test_transform_point_refuses_wrong_shape() -> None:
    with pytest.raises(TransformError, match="3 coordinates"):
        transform_point(np.eye(4), [1.0, 2.0])


# --- validation -----------------------------------------------------------------------------------


@given(transforms)
def test_float32_rounded_transform_is_accepted(T: NDArray[np.float64]) -> None:
    T32 = T.astype(np.float32).astype(np.float64)
    np.testing.assert_array_equal(validate_transform(T32, "float32 file"), T32)


def _defect(name: str) -> NDArray[np.float64]:
    T = ur_pose_to_matrix([0.1, 0.2, 0.3, 0.4, -0.5, 0.6])
    if name == "nan":
        T[1, 3] = math.nan
    elif name == "inf":
        T[0, 0] = math.inf
    elif name == "bottom row":
        T[3, 0] = 0.1
    elif name == "scaled":
        T[:3, :3] *= 1.001
    elif name == "sheared":
        T[0, 1] += 1e-4
    elif name == "reflection":
        T[:3, 2] *= -1.0
    return T


@pytest.mark.parametrize(
    ("defect", "message"),
    [
        ("nan", "non-finite"),
        ("inf", "non-finite"),
        ("bottom row", r"bottom row must be \[0, 0, 0, 1\]"),
        ("scaled", "not orthonormal"),
        ("sheared", "not orthonormal"),
        ("reflection", "determinant -1"),
    ],
)
def test_validator_names_source_and_defect(defect: str, message: str) -> None:
    with pytest.raises(TransformError, match=message) as info:
        validate_transform(_defect(defect), "cell.yaml: T_base_cam")
    assert str(info.value).startswith("cell.yaml: T_base_cam: ")


@pytest.mark.parametrize("bad", [np.eye(3), np.eye(4)[:3], [[1, 2], [3, 4]], "abc"])
def test_validator_refuses_wrong_shape_or_type(bad: object) -> None:
    with pytest.raises(TransformError, match="src"):
        validate_transform(bad, "src")  # type: ignore[arg-type]


def test_validator_returns_a_float64_copy() -> None:
    T_int = np.eye(4, dtype=np.int64)
    T = validate_transform(T_int, "ints")
    assert T.dtype == np.float64
    T[0, 3] = 5.0
    assert T_int[0, 3] == 0


def test_validate_rotation_refuses_wrong_shape() -> None:
    with pytest.raises(TransformError, match="3x3"):
        validate_rotation(np.eye(4), "R")


# --- units ----------------------------------------------------------------------------------------


def test_metres_per_and_scale_translation() -> None:
    assert metres_per("mm") == 1e-3
    assert metres_per("m") == 1.0
    with pytest.raises(TransformError, match="unknown length unit 'cm'"):
        metres_per("cm")
    T_mm = make_transform(rotation_about(0, 0.3), [100.0, -20.0, 5.0])
    T_m = scale_translation(T_mm, metres_per("mm"))
    np.testing.assert_allclose(T_m[:3, 3], [0.1, -0.02, 0.005], atol=1e-15)
    np.testing.assert_array_equal(T_m[:3, :3], T_mm[:3, :3])
    assert T_mm[0, 3] == 100.0  # the input is not modified


# --- agreement with scipy's Rotation, an independent implementation ------------------------------
# The package converts rotations in closed form (importing scipy.spatial costs a command most of
# its start-up time); scipy stays the reference the closed forms are checked against.

ALL_SEQUENCES = [
    "".join(axes) for axes in itertools.product("xyz", repeat=3) if axes[0] != axes[1] != axes[2]
]
ALL_SEQUENCES += [sequence.upper() for sequence in ALL_SEQUENCES]

@given(rotvecs)
def test_rotvec_conversions_agree_with_scipy(rotvec: NDArray[np.float64]) -> None:
    R_ref = Rotation.from_rotvec(rotvec).as_matrix()
    np.testing.assert_allclose(rotation_from_rotvec(rotvec), R_ref, atol=1e-15)
    back = rotation_to_rotvec(R_ref)
    np.testing.assert_allclose(
        np.linalg.norm(back), np.linalg.norm(Rotation.from_matrix(R_ref).as_rotvec()), atol=1e-12
    )
    assert rotation_angle_between(rotation_from_rotvec(back), R_ref) < ROT_TOL


@given(rotations)
def test_quaternion_agrees_with_scipy_canonical(R: NDArray[np.float64]) -> None:
    ours = rotation_to_quaternion(R, "xyzw")
    ref = Rotation.from_matrix(R).as_quat(canonical=True)
    if abs(ref[3]) < 1e-9:  # at 180 degrees the sign hangs on the last bit of w
        ours = ours * np.sign(ours @ ref)
    np.testing.assert_allclose(ours, ref, atol=1e-12)
    np.testing.assert_allclose(rotation_from_quaternion(ref, "xyzw"), R, atol=1e-12)


@given(st.tuples(*(st.floats(-math.pi, math.pi) for _ in range(3))), st.sampled_from(ALL_SEQUENCES))
def test_rotation_from_euler_agrees_with_scipy(abc: tuple[float, ...], sequence: str) -> None:
    R_ref = Rotation.from_euler(sequence, abc).as_matrix()
    np.testing.assert_allclose(rotation_from_euler(abc, sequence, "rad"), R_ref, atol=1e-15)


@given(rotations, st.sampled_from(ALL_SEQUENCES))
def test_euler_angles_agree_with_scipy(R: NDArray[np.float64], sequence: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # scipy warns about gimbal lock
        ref = Rotation.from_matrix(R).as_euler(sequence)
    ours = rotation_to_euler(R, sequence, "rad")
    # Angles are compared where they are well defined: away from gimbal lock (where only the
    # rotation is, see test_euler_round_trip), and modulo 2 pi (-pi and pi are one angle).
    middle_from_lock = ref[1] if sequence[0] == sequence[2] else abs(ref[1]) - math.pi / 2
    if min(abs(middle_from_lock), abs(abs(ref[1]) - math.pi)) > 1e-6:
        wrapped = np.angle(np.exp(1j * (ours - ref)))
        np.testing.assert_allclose(wrapped, 0.0, atol=1e-8)


@pytest.mark.parametrize("sequence", ALL_SEQUENCES)
@pytest.mark.parametrize("lock", ["low", "high"])
def test_gimbal_lock_sets_the_third_angle_to_zero_as_scipy_does(sequence: str, lock: str) -> None:
    proper = sequence[0] == sequence[2]
    middle = {"low": 0.0 if proper else -math.pi / 2, "high": math.pi if proper else math.pi / 2}
    R = rotation_from_euler([0.3, middle[lock], -1.1], sequence, "rad")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # scipy warns about the lock
        ref = Rotation.from_matrix(R).as_euler(sequence)
    ours = rotation_to_euler(R, sequence, "rad")
    assert ours[2] == 0.0
    np.testing.assert_allclose(ours, ref, atol=1e-9)
    assert rotation_angle_between(rotation_from_euler(ours, sequence, "rad"), R) < ROT_TOL
