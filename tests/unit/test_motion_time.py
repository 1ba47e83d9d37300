"""The session's motion-time model (cell/motion_time.py) and the choice it drives
(cell/stretch.py): properties of the profile maths, and a stretch kept or turned into stops by
what a path start costs."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from handeye_pick.cell.blend import with_blends
from handeye_pick.cell.motion_time import Piece, path_time_s, trapezoid_s
from handeye_pick.cell.stretch import paying_blends
from handeye_pick.config.schema import MotionConfig
from handeye_pick.geometry import make_transform
from handeye_pick.steps import Move

lengths = st.floats(0.001, 2.0)
speeds = st.floats(0.01, 3.0)
accels = st.floats(0.1, 20.0)


@given(lengths, speeds, accels)
def test_one_piece_is_a_trapezoid(length: float, speed: float, accel: float) -> None:
    assert math.isclose(
        path_time_s([Piece(length, speed)], accel), trapezoid_s(length, speed, accel), rel_tol=1e-9
    )


@given(lengths, lengths, speeds, accels)
def test_a_piece_cut_in_two_at_one_cap_takes_as_long_as_the_whole(
    a: float, b: float, speed: float, accel: float
) -> None:
    cut = path_time_s([Piece(a, speed), Piece(b, speed)], accel)
    assert math.isclose(cut, trapezoid_s(a + b, speed, accel), rel_tol=1e-9)


@given(st.lists(st.tuples(lengths, speeds), min_size=1, max_size=6), accels)
def test_never_stopping_is_never_slower_than_stopping_at_every_boundary(
    pieces: list[tuple[float, float]], accel: float
) -> None:
    through = path_time_s([Piece(length, speed) for length, speed in pieces], accel)
    stops = sum(trapezoid_s(length, speed, accel) for length, speed in pieces)
    assert through <= stops * (1 + 1e-9)


@given(st.lists(st.tuples(lengths, speeds), min_size=2, max_size=6), accels, st.floats(1.0, 3.0))
def test_a_higher_cap_is_never_slower(
    pieces: list[tuple[float, float]], accel: float, factor: float
) -> None:
    base = [Piece(length, speed) for length, speed in pieces]
    faster = [Piece(base[0].length, base[0].speed * factor), *base[1:]]
    assert path_time_s(faster, accel) <= path_time_s(base, accel) * (1 + 1e-9)


MOTION = MotionConfig(speed_mps=1.0, accel_mps2=1.2, grasp_speed_mps=0.1, blend_mm=50.0)


def _at(x: float, y: float) -> np.ndarray:
    return make_transform(np.diag([1.0, -1.0, -1.0]), np.array([x, y, 0.3]))


def _gentle() -> list[Move]:
    """Three 200 mm legs turning by some 15 degrees: corners that save about a second."""
    moves = [Move("a", _at(0.0, 0.2)), Move("b", _at(0.04, 0.4)), Move("c", _at(0.1, 0.6))]
    rounded = with_blends(moves, _at(0.0, 0.0), 0.05, 0.02)
    assert all(m.blend_m > 0 for m in rounded[:2])  # type: ignore[union-attr]
    return rounded  # type: ignore[return-value]


def test_a_stretch_is_kept_where_its_corners_save_more_than_the_start() -> None:
    steps, (stretch,) = paying_blends(_gentle(), _at(0.0, 0.0), MOTION, 0.1)
    assert stretch.pays
    assert stretch.record()["sent"] == "blended"
    assert [m.blend_m for m in steps] == [m.blend_m for m in _gentle()]  # type: ignore[union-attr]


def test_a_stretch_turns_into_stops_where_the_start_costs_more_than_its_corners_save() -> None:
    steps, (stretch,) = paying_blends(_gentle(), _at(0.0, 0.0), MOTION, 5.0)
    assert not stretch.pays
    assert stretch.record()["sent"] == "stop-and-go"
    assert [m.blend_m for m in steps] == [0.0, 0.0, 0.0]  # type: ignore[union-attr]
    assert [m.name for m in steps] == ["a", "b", "c"]
