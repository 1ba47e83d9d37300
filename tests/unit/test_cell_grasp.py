"""Pick targets: approach/retreat along the grasp's own tool z, position-only picks point down."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from handeye_pick.cell.grasp import plan_targets, tool_down_keeping_yaw
from handeye_pick.config.schema import GraspConfig
from handeye_pick.geometry import (
    make_transform,
    rotation_angle_between,
    rotation_from_euler,
    rotation_from_quaternion,
)
from handeye_pick.safety import tilt_deg

DOWN = np.array([0.0, 0.0, -1.0])

finite = st.floats(-1.0, 1.0, allow_nan=False)
quaternions = st.tuples(finite, finite, finite, finite).filter(
    lambda q: float(np.linalg.norm(q)) > 0.1
)
rotations = quaternions.map(
    lambda q: rotation_from_quaternion(np.array(q) / np.linalg.norm(q), "xyzw")
)
positions = st.tuples(finite, finite, finite).map(np.array)
standoffs_mm = st.floats(5.0, 500.0, allow_nan=False)
yaws = st.floats(-math.pi, math.pi, allow_nan=False)


def _tool_down(yaw_rad: float) -> NDArray[np.float64]:
    """Tool z straight down, tool x at ``yaw_rad`` about base z."""
    return rotation_from_euler([math.pi, 0.0, yaw_rad], "xyz", "rad")


def _config(
    approach_mm: float = 100.0,
    retreat_mm: float = 100.0,
    T_obj_tcp: NDArray[np.float64] | None = None,
) -> GraspConfig:
    return GraspConfig(
        approach_mm=approach_mm,
        retreat_mm=retreat_mm,
        T_obj_tcp=np.eye(4) if T_obj_tcp is None else T_obj_tcp,
    )


@settings(max_examples=200, deadline=None)
@given(
    R_obj=rotations,
    p_obj=positions,
    R_off=rotations,
    p_off=positions,
    approach_mm=standoffs_mm,
    retreat_mm=standoffs_mm,
)
def test_oriented_grasp_follows_object_and_backs_off_along_tool_z(
    R_obj: NDArray[np.float64],
    p_obj: NDArray[np.float64],
    R_off: NDArray[np.float64],
    p_off: NDArray[np.float64],
    approach_mm: float,
    retreat_mm: float,
) -> None:
    T_base_obj = make_transform(R_obj, p_obj)
    T_obj_tcp = make_transform(R_off, p_off * 0.1)
    now = make_transform(_tool_down(0.3), [0.4, 0.0, 0.5])
    targets = plan_targets(T_base_obj, now, _config(approach_mm, retreat_mm, T_obj_tcp), False)

    np.testing.assert_allclose(targets.grasp, T_base_obj @ T_obj_tcp, atol=1e-12)
    z_tool = targets.grasp[:3, 2]
    for target, distance_mm in ((targets.approach, approach_mm), (targets.retreat, retreat_mm)):
        np.testing.assert_array_equal(target[:3, :3], targets.grasp[:3, :3])
        back = target[:3, 3] - targets.grasp[:3, 3]
        assert math.isclose(np.linalg.norm(back), distance_mm / 1000.0, rel_tol=1e-9)
        np.testing.assert_allclose(back, -distance_mm / 1000.0 * z_tool, atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(
    yaw=yaws, R_obj=rotations, p_obj=positions, approach_mm=standoffs_mm, retreat_mm=standoffs_mm
)
def test_position_only_points_down_keeps_current_yaw_and_backs_off_straight_up(
    yaw: float,
    R_obj: NDArray[np.float64],
    p_obj: NDArray[np.float64],
    approach_mm: float,
    retreat_mm: float,
) -> None:
    now = make_transform(_tool_down(yaw), [0.3, -0.2, 0.6])
    # The detected rotation and the grasp offset mean nothing for a position-only pick.
    T_base_obj = make_transform(R_obj, p_obj)
    offset = make_transform(rotation_from_euler([10, 20, 30], "xyz", "deg"), [0.01, 0, 0])
    targets = plan_targets(T_base_obj, now, _config(approach_mm, retreat_mm, offset), True)

    np.testing.assert_allclose(targets.grasp[:3, 3], p_obj, atol=1e-15)
    np.testing.assert_array_equal(targets.grasp[:3, 2], DOWN)
    assert rotation_angle_between(targets.grasp[:3, :3], now[:3, :3]) < 1e-9  # yaw kept
    np.testing.assert_allclose(
        targets.approach[:3, 3] - targets.grasp[:3, 3], [0, 0, approach_mm / 1000.0], atol=1e-12
    )
    np.testing.assert_allclose(
        targets.retreat[:3, 3] - targets.grasp[:3, 3], [0, 0, retreat_mm / 1000.0], atol=1e-12
    )


@settings(max_examples=300, deadline=None)
@given(R_now=rotations)
def test_tool_down_is_the_smallest_tilt_of_the_current_tool(R_now: NDArray[np.float64]) -> None:
    R = tool_down_keeping_yaw(R_now)
    assert rotation_angle_between(R.T @ R, np.eye(3)) < 1e-12
    assert math.isclose(np.linalg.det(R), 1.0, abs_tol=1e-12)
    np.testing.assert_array_equal(R[:, 2], DOWN)
    # The grasp differs from the current rotation by the tilt alone: no yaw was added.
    if tilt_deg(make_transform(R_now, [0, 0, 0])) < 179.0:
        angle = math.degrees(rotation_angle_between(R_now, R))
        assert math.isclose(angle, tilt_deg(make_transform(R_now, [0, 0, 0])), abs_tol=1e-6)


def test_tilted_tool_keeps_its_heading() -> None:
    # Tool tilted 40 degrees about its own x axis, x heading 30 degrees: the pick keeps 30.
    R_now = _tool_down(math.radians(30)) @ rotation_from_euler([40, 0, 0], "xyz", "deg")
    R = tool_down_keeping_yaw(R_now)
    assert math.isclose(math.degrees(math.atan2(R[1, 0], R[0, 0])), 30.0, abs_tol=1e-9)


def test_tool_pointing_straight_up_is_turned_over_about_its_x_axis() -> None:
    R_up = rotation_from_euler([0, 0, 25], "xyz", "deg")
    R = tool_down_keeping_yaw(R_up)
    np.testing.assert_array_equal(R[:, 2], DOWN)
    np.testing.assert_allclose(R[:, 0], R_up[:, 0], atol=1e-12)


def test_approach_mm_is_millimetres_along_tool_z_not_metres_nor_base_z() -> None:
    # A grasp tilted 30 degrees: tool z is not base -z, so "along base z" would differ.
    T_base_obj = make_transform(
        rotation_from_euler([180 + 30, 0, 0], "xyz", "deg"), [0.5, 0.1, 0.2]
    )
    now = make_transform(_tool_down(0.0), [0.5, 0.1, 0.5])
    targets = plan_targets(T_base_obj, now, _config(approach_mm=100, retreat_mm=50), False)
    grasp, approach = targets.grasp[:3, 3], targets.approach[:3, 3]
    z_tool = targets.grasp[:3, 2]

    assert math.isclose(np.linalg.norm(approach - grasp), 0.1, rel_tol=1e-12)  # not 100 m
    np.testing.assert_allclose(approach, grasp - 0.1 * z_tool, atol=1e-12)
    assert (
        np.linalg.norm(approach - (grasp + np.array([0.0, 0.0, 0.1]))) > 0.02
    )  # not straight up in base
    assert approach[2] > grasp[2]  # backed away from the object, not into it
    assert math.isclose(np.linalg.norm(targets.retreat[:3, 3] - grasp), 0.05, rel_tol=1e-12)
