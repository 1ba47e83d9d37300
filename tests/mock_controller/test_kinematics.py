"""Properties of the simulated controller's kinematics (nominal UR e-Series DH, metres, radians)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from mocks.ur_controller.kinematics import (
    IK_TOLERANCE,
    LIMIT_TOLERANCE_RAD,
    MODELS,
    URModel,
    flange_from_tcp,
    forward,
    interpolate_pose,
    inverse,
    inverse_all,
    matrix_to_pose,
    pose_to_matrix,
    reachable,
    tcp_from_flange,
    trapezoid,
    trapezoid_fraction,
    within_limits,
)

TWO_PI = 2.0 * math.pi
JOINT_TOLERANCE_RAD = 1e-6
"""IK recovers joints to ~1e-7 rad on a stretched arm (q3 = 0 is an ill-conditioned square root)."""

model_names = st.sampled_from(sorted(MODELS))
joint_angle = st.floats(min_value=-TWO_PI, max_value=TWO_PI, allow_nan=False)
joint_vectors = st.lists(joint_angle, min_size=6, max_size=6).map(np.array)
unit_vectors = (
    st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3)
    .map(np.array)
    .filter(lambda v: float(np.linalg.norm(v)) > 1e-3)
    .map(lambda v: v / np.linalg.norm(v))
)
# Rotation angles with extra weight at and just below pi, where rotation vectors flip sign.
rotation_angles = st.one_of(
    st.floats(0.0, math.pi),
    st.sampled_from([0.0, math.pi, math.nextafter(math.pi, 0.0), math.pi - 1e-9, math.pi - 1e-6]),
)


def rotation_error_rad(R1: NDArray[np.float64], R2: NDArray[np.float64]) -> float:
    """Angle of the rotation taking R1 to R2, the only fair way to compare rotations."""
    return float(Rotation.from_matrix(R1.T @ R2).magnitude())


def transform_error(T1: NDArray[np.float64], T2: NDArray[np.float64]) -> float:
    return float(np.max(np.abs(T1[:3] - T2[:3])))


def assert_reaches(model: URModel, q: NDArray[np.float64], T: NDArray[np.float64]) -> None:
    """q from ``inverse`` reaches T: to IK precision, or to what snapping onto a limit costs."""
    on_limit = bool(np.any(np.abs(q) == TWO_PI))
    tolerance = LIMIT_TOLERANCE_RAD * 2.0 if on_limit else 10 * IK_TOLERANCE
    assert transform_error(forward(model, q), T) <= tolerance


def wrist_centre_offset_m(model_name: str, q: NDArray[np.float64]) -> float:
    """How far the wrist centre is from the shoulder-singular cylinder of radius d4."""
    model = MODELS[model_name]
    T = forward(model, q)
    p05 = T[:3, 3] - model.d[5] * T[:3, 2]
    return abs(math.hypot(p05[0], p05[1]) - model.d[3])


# --- forward kinematics -------------------------------------------------------------------------


def test_ur5e_flange_at_zero_matches_published_closed_form() -> None:
    T = forward(MODELS["ur5e"], np.zeros(6))
    np.testing.assert_allclose(T[:3, 3], [-0.8172, -0.2329, 0.0628], atol=1e-12)
    # alpha sums to +pi/2 about x: flange z points along base -y.
    np.testing.assert_allclose(T[:3, :3], [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-12)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_every_model_at_zero_matches_dh_closed_form(name: str) -> None:
    model = MODELS[name]
    d1, d4, d5, d6 = model.d[0], model.d[3], model.d[4], model.d[5]
    a2, a3 = model.a[1], model.a[2]
    T = forward(model, np.zeros(6))
    np.testing.assert_allclose(T[:3, 3], [a2 + a3, -(d4 + d6), d1 - d5], atol=1e-12)


def test_models_carry_e_series_limits_and_reach() -> None:
    assert sorted(MODELS) == ["ur10e", "ur16e", "ur3e", "ur5e"]
    for model in MODELS.values():
        assert model.joint_min_rad == (-TWO_PI,) * 6
        assert model.joint_max_rad == (TWO_PI,) * 6
        assert 0.4 < model.reach_m < 1.4


# --- inverse kinematics -------------------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(name=model_names, q=joint_vectors)
# Stretched arm with a nearly singular wrist: q6 rounded by 3e-9 rad put the arm out of reach.
@example(name="ur10e", q=np.array([0.0, 0.0, 0.0, -1.0, -9.5385721209193e-09, 0.0]))
def test_every_ik_solution_reproduces_the_forward_pose(name: str, q: NDArray[np.float64]) -> None:
    model = MODELS[name]
    T = forward(model, q)
    solutions = inverse_all(model, T)
    assert 1 <= len(solutions) <= 8
    for solution in solutions:
        assert not np.any(np.isnan(solution))
        assert transform_error(forward(model, solution), T) <= IK_TOLERANCE
    assert reachable(model, T)


@settings(max_examples=300, deadline=None)
@given(name=model_names, q=joint_vectors)
def test_nearest_solution_to_q_is_q(name: str, q: NDArray[np.float64]) -> None:
    # Away from singularities the solution is isolated, so the nearest one must be q itself.
    assume(abs(math.sin(q[4])) > 1e-3)
    assume(abs(math.sin(q[2])) > 1e-3)
    assume(wrist_centre_offset_m(name, q) > 1e-4)
    model = MODELS[name]
    solution = inverse(model, forward(model, q), q)
    assert solution is not None
    np.testing.assert_allclose(solution, q, atol=1e-9)


@settings(max_examples=200, deadline=None)
@given(name=model_names, q=joint_vectors, shift=st.floats(-1.0, 1.0))
def test_nearest_solution_is_within_limits_and_near(
    name: str, q: NDArray[np.float64], shift: float
) -> None:
    assume(abs(math.sin(q[4])) > 1e-6)  # a singular wrist has a continuum of solutions
    assume(abs(math.sin(q[2])) > 1e-3)  # a stretched arm recovers joints to ~1e-6 rad only
    model = MODELS[name]
    q_near = np.clip(q + shift, -TWO_PI, TWO_PI)
    T = forward(model, q)
    solution = inverse(model, T, q_near)
    assert solution is not None
    assert within_limits(model, solution)
    assert_reaches(model, solution, T)
    # q is one of the candidates, so the chosen one can be no farther from q_near.
    assert np.linalg.norm(solution - q_near) <= np.linalg.norm(q - q_near) + JOINT_TOLERANCE_RAD


@settings(max_examples=200, deadline=None)
@given(
    name=model_names,
    q=joint_vectors,
    q5=st.sampled_from([0.0, math.pi, -math.pi]),
    q6_near_shift=st.floats(-1.0, 1.0),
)
def test_singular_wrist_gives_no_nan_and_prefers_q6_near(
    name: str, q: NDArray[np.float64], q5: float, q6_near_shift: float
) -> None:
    model = MODELS[name]
    q[4] = q5
    T = forward(model, q)
    # q itself solves T, so asking near q must give q back.
    same = inverse(model, T, q)
    assert same is not None
    np.testing.assert_allclose(same, q, atol=JOINT_TOLERANCE_RAD)

    q_near = q.copy()
    q_near[5] = float(np.clip(q[5] + q6_near_shift, -TWO_PI, TWO_PI))
    for candidate in inverse_all(model, T, q6_if_singular=q_near[5]):
        assert not np.any(np.isnan(candidate))
    solution = inverse(model, T, q_near)
    assert solution is not None
    assert not np.any(np.isnan(solution))
    assert_reaches(model, solution, T)
    # q6 is free on a singular wrist: it is the caller's unless the arm cannot reach with it, and
    # then the chosen q6 leaves the arm at the edge of its reach (stretched or folded, sin q3 = 0).
    singular = abs(math.sin(solution[4])) < 1e-9
    if singular and solution[5] != pytest.approx(q_near[5], abs=1e-9):
        assert abs(math.sin(solution[2])) < 1e-6


def test_stretched_singular_arm_takes_the_only_q6_that_reaches() -> None:
    model = MODELS["ur5e"]
    q = np.array([0.0, 0.0, 0.0, 0.0, math.pi, 0.0])
    solution = inverse(model, forward(model, q), [0.0, 0.0, 0.0, 0.0, math.pi, 1.0])
    assert solution is not None
    np.testing.assert_allclose(solution, q, atol=JOINT_TOLERANCE_RAD)


@settings(max_examples=100, deadline=None)
@given(name=model_names, direction=unit_vectors, angle=rotation_angles, axis=unit_vectors)
def test_pose_two_metres_away_is_unreachable(
    name: str, direction: NDArray[np.float64], angle: float, axis: NDArray[np.float64]
) -> None:
    model = MODELS[name]
    T = pose_to_matrix(np.concatenate([2.0 * direction, angle * axis]))
    assert inverse(model, T, np.zeros(6)) is None
    assert inverse_all(model, T) == []
    assert not reachable(model, T)


def test_within_limits_is_inclusive_at_two_pi() -> None:
    model = MODELS["ur5e"]
    assert within_limits(model, [TWO_PI, -TWO_PI, 0.0, 0.0, 0.0, 0.0])
    assert not within_limits(model, [TWO_PI + 0.01, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert not within_limits(model, [0.0, 0.0, 0.0, 0.0, 0.0, -TWO_PI - 0.01])


def test_inverse_rejects_a_malformed_q_near() -> None:
    model = MODELS["ur5e"]
    with pytest.raises(ValueError, match=r"inverse: q_near must have shape \(6,\)"):
        inverse(model, forward(model, np.zeros(6)), [0.0, 0.0])


# --- pose vectors and frames --------------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(
    position=st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3),
    axis=unit_vectors,
    angle=rotation_angles,
)
def test_pose_matrix_round_trip_including_pi(
    position: list[float], axis: NDArray[np.float64], angle: float
) -> None:
    pose = np.concatenate([position, angle * axis])
    T = pose_to_matrix(pose)
    back = matrix_to_pose(T)
    np.testing.assert_allclose(back[:3], position, atol=1e-15)
    assert np.linalg.norm(back[3:]) <= math.pi + 1e-12
    assert rotation_error_rad(pose_to_matrix(back)[:3, :3], T[:3, :3]) <= 1e-9
    expected = Rotation.from_rotvec(angle * axis).as_matrix()
    assert rotation_error_rad(T[:3, :3], expected) <= 1e-9


def test_rotation_vectors_either_side_of_pi_are_close_rotations() -> None:
    T_plus = pose_to_matrix([0.0, 0.0, 0.0, 0.0, 3.1415, 0.0])
    T_minus = pose_to_matrix([0.0, 0.0, 0.0, 0.0, -3.1415, 0.0])
    assert rotation_error_rad(T_plus[:3, :3], T_minus[:3, :3]) == pytest.approx(
        2 * math.pi - 2 * 3.1415, abs=1e-12
    )
    back = matrix_to_pose(pose_to_matrix([0.0, 0.0, 0.0, 0.0, -math.pi, 0.0]))
    assert abs(back[4]) == pytest.approx(math.pi, abs=1e-12)


def test_tcp_offset_moves_along_flange_axes() -> None:
    # Flange rotated +90 deg about base x: flange z points along base -y.
    T_base_flange = pose_to_matrix([0.3, 0.1, 0.5, math.pi / 2, 0.0, 0.0])
    tcp_offset_pose = [0.0, 0.0, 0.2, 0.0, 0.0, 0.0]
    T_base_tcp = tcp_from_flange(T_base_flange, tcp_offset_pose)
    np.testing.assert_allclose(T_base_tcp[:3, 3], [0.3, -0.1, 0.5], atol=1e-12)
    assert transform_error(flange_from_tcp(T_base_tcp, tcp_offset_pose), T_base_flange) < 1e-12


@settings(max_examples=100, deadline=None)
@given(
    name=model_names,
    q=joint_vectors,
    offset=st.lists(st.floats(-0.3, 0.3), min_size=6, max_size=6),
)
def test_flange_from_tcp_undoes_tcp_from_flange(
    name: str, q: NDArray[np.float64], offset: list[float]
) -> None:
    T_base_flange = forward(MODELS[name], q)
    T_base_tcp = tcp_from_flange(T_base_flange, offset)
    assert transform_error(flange_from_tcp(T_base_tcp, offset), T_base_flange) < 1e-12


# --- interpolation and motion profile -----------------------------------------------------------


@settings(max_examples=200, deadline=None)
@given(
    angle=st.floats(0.0, math.pi - 1e-3),
    axis=unit_vectors,
    start=st.lists(st.floats(-1.0, 1.0), min_size=6, max_size=6),
    end=st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3),
    s=st.floats(0.0, 1.0),
)
def test_interpolate_pose_is_linear_in_position_and_slerp_in_rotation(
    angle: float,
    axis: NDArray[np.float64],
    start: list[float],
    end: list[float],
    s: float,
) -> None:
    T0 = pose_to_matrix(start)
    T1 = T0 @ pose_to_matrix([0.0, 0.0, 0.0, *(angle * axis)])
    T1[:3, 3] = end
    T = interpolate_pose(T0, T1, s)
    np.testing.assert_allclose(T[:3, 3], (1 - s) * T0[:3, 3] + s * np.array(end), atol=1e-12)
    assert rotation_error_rad(T0[:3, :3], T[:3, :3]) == pytest.approx(s * angle, abs=1e-9)
    assert rotation_error_rad(T[:3, :3], T1[:3, :3]) == pytest.approx((1 - s) * angle, abs=1e-9)


def test_interpolate_pose_ends_are_the_inputs() -> None:
    T0 = pose_to_matrix([0.1, 0.2, 0.3, 0.0, 0.0, 1.0])
    T1 = pose_to_matrix([-0.4, 0.0, 0.6, 0.0, 2.0, 0.0])
    assert transform_error(interpolate_pose(T0, T1, 0.0), T0) < 1e-12
    assert transform_error(interpolate_pose(T0, T1, 1.0), T1) < 1e-12
    with pytest.raises(ValueError, match="interpolate_pose: fraction s must be in"):
        interpolate_pose(T0, T1, 1.5)


def sampled_profile(
    distance: float, v_max: float, a_max: float, samples: int = 2000
) -> tuple[float, NDArray[np.float64], float]:
    """Duration, sampled positions (in distance units) and the sampling step of one move."""
    duration = trapezoid(distance, v_max, a_max)
    dt = duration / samples
    positions = np.array(
        [distance * trapezoid_fraction(i * dt, distance, v_max, a_max) for i in range(samples + 1)]
    )
    return duration, positions, dt


profile_args = {
    "distance": st.floats(1e-4, 3.0),
    "v_max": st.floats(0.01, 3.0),
    "a_max": st.floats(0.05, 150.0),
}


@settings(max_examples=100, deadline=None)
@given(**profile_args)
def test_trapezoid_honours_speed_and_acceleration(
    distance: float, v_max: float, a_max: float
) -> None:
    duration, positions, dt = sampled_profile(distance, v_max, a_max)
    if distance >= v_max**2 / a_max:
        assert duration == pytest.approx(distance / v_max + v_max / a_max, rel=1e-12)
    else:
        assert duration == pytest.approx(2 * math.sqrt(distance / a_max), rel=1e-12)
    assert positions[0] == 0.0
    assert positions[-1] == distance
    # Mean speed and mean acceleration over any window are bounded by the peak values.
    speeds = np.diff(positions) / dt
    assert np.all(speeds >= -1e-12)
    assert np.max(speeds) <= v_max * (1 + 1e-9)
    accelerations = np.diff(positions, 2) / dt**2
    assert np.max(np.abs(accelerations)) <= a_max * (1 + 1e-6)


@settings(max_examples=100, deadline=None)
@given(**profile_args)
def test_short_moves_are_triangular(distance: float, v_max: float, a_max: float) -> None:
    v_max = max(v_max, 2.0 * math.sqrt(distance * a_max))  # too short to reach v_max
    duration, positions, dt = sampled_profile(distance, v_max, a_max)
    assert duration == pytest.approx(2 * math.sqrt(distance / a_max), rel=1e-12)
    speeds = np.diff(positions) / dt
    assert np.max(speeds) == pytest.approx(math.sqrt(distance * a_max), rel=2e-3)
    assert trapezoid_fraction(duration / 2, distance, v_max, a_max) == pytest.approx(0.5)


def test_trapezoid_edge_cases() -> None:
    assert trapezoid(0.0, 0.25, 1.2) == 0.0
    assert trapezoid_fraction(0.0, 0.0, 0.25, 1.2) == 1.0
    assert trapezoid_fraction(-1.0, 0.5, 0.25, 1.2) == 0.0
    assert trapezoid_fraction(100.0, 0.5, 0.25, 1.2) == 1.0
    with pytest.raises(ValueError, match="trapezoid: v_max must be finite and > 0"):
        trapezoid(0.5, 0.0, 1.2)
    with pytest.raises(ValueError, match="trapezoid: distance must be finite and >= 0"):
        trapezoid(-0.1, 0.25, 1.2)
