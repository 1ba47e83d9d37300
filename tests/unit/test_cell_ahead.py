"""``cell.ahead.start_problem``: the arm is where a pick checked ahead starts when the TCP is
within 1 mm and 0.1 deg and every joint within 0.1 deg of what the check assumed."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from handeye_pick.cell.ahead import (
    START_TOLERANCE_M,
    START_TOLERANCE_RAD,
    AheadStart,
    start_problem,
)
from handeye_pick.geometry import Transform, make_transform, rotation_from_rotvec

unit = st.floats(-1.0, 1.0, allow_nan=False)
vectors = st.tuples(unit, unit, unit).filter(lambda v: np.linalg.norm(v) > 0.1)
rotvecs = st.tuples(unit, unit, unit).map(lambda v: np.array(v) * 2.0)
joints = st.lists(st.floats(-3.0, 3.0), min_size=6, max_size=6).map(tuple)


def _start(T: Transform, q: tuple[float, ...] | None) -> AheadStart:
    return AheadStart(T, q, np.eye(4), None)


def _pose(rotvec: np.ndarray, position: tuple[float, float, float]) -> Transform:
    return make_transform(rotation_from_rotvec(rotvec), np.array(position) * 0.5)


@given(rotvecs, vectors, vectors, st.floats(0.0, 0.95), st.floats(1.05, 3.0))
def test_the_tcp_within_one_millimetre_is_where_it_started(
    rotvec: np.ndarray,
    position: tuple[float, float, float],
    direction: tuple[float, float, float],
    inside: float,
    outside: float,
) -> None:
    T = _pose(rotvec, position)
    step = np.array(direction) / np.linalg.norm(direction) * START_TOLERANCE_M
    near, far = T.copy(), T.copy()
    near[:3, 3] += step * inside
    far[:3, 3] += step * outside
    assert start_problem(_start(T, None), near, (0.0,) * 6) is None
    problem = start_problem(_start(T, None), far, (0.0,) * 6)
    assert problem is not None
    assert "mm" in problem


@given(rotvecs, vectors, st.floats(0.0, 0.95), st.floats(1.05, 3.0))
def test_the_tool_turned_more_than_a_tenth_of_a_degree_is_elsewhere(
    rotvec: np.ndarray, axis: tuple[float, float, float], inside: float, outside: float
) -> None:
    T = _pose(rotvec, (0.1, 0.2, 0.3))
    turn = np.array(axis) / np.linalg.norm(axis) * START_TOLERANCE_RAD

    def turned(share: float) -> Transform:
        out = T.copy()
        out[:3, :3] = rotation_from_rotvec(turn * share) @ T[:3, :3]
        return out

    assert start_problem(_start(T, None), turned(inside), (0.0,) * 6) is None
    assert start_problem(_start(T, None), turned(outside), (0.0,) * 6) is not None


@given(joints, st.integers(0, 5), st.floats(0.0, 0.95), st.floats(1.05, 3.0))
def test_every_joint_must_be_within_a_tenth_of_a_degree_when_the_check_knew_them(
    q: tuple[float, ...], joint: int, inside: float, outside: float
) -> None:
    T = _pose(np.zeros(3), (0.1, 0.2, 0.3))

    def moved(share: float) -> tuple[float, ...]:
        out = list(q)
        out[joint] += START_TOLERANCE_RAD * share
        return tuple(out)

    assert start_problem(_start(T, q), T, moved(inside)) is None
    problem = start_problem(_start(T, q), T, moved(outside))
    assert problem is not None
    assert "joint" in problem
    assert start_problem(_start(T, None), T, moved(outside)) is None  # joints not checked


def test_the_tolerance_is_one_millimetre_and_a_tenth_of_a_degree() -> None:
    assert START_TOLERANCE_M == 0.001
    assert math.isclose(math.degrees(START_TOLERANCE_RAD), 0.1)
